"""The auditory perception module: from the step-0 binaural clip, the fallen object's
category, its audio material and where the fall was (azimuth and distance from the agent).

Trained on a build's train split, scored on another split (``fallgen audio-model train`` /
``eval``). The features are :class:`~fallgen.perception.audio_features.AudioFeatures`; the
models scikit-learn's extremely randomised trees (Geurts, Ernst & Wehenkel 2006): a classifier
each for the category and the material on every feature, a regressor for (cos azimuth, sin
azimuth) together on the spatial ones (``AudioFeatures.spatial``); and gradient-boosted trees
(scikit-learn's histogram boosting) for the log distance on every feature (the object's kind
tells how loud and how long it rings, the direct-to-reverberant ratios how far: on the
paper-size build boosting ranks the test falls' distances at 0.45 where the randomised trees
reach 0.43 on the same features). Seeded, and deterministic for a seed on a given machine and
library version (the boosting on one thread too).

The model file (pickle through joblib: load only files you trust) holds the feature settings,
the label tables and the train split's manifest hash; a dataset whose clips differ from the
features' (sample rate, length) is refused with a one-line error. Scored against a prior that
does not listen: the train split's most frequent categories and material, and the room's
centre as where the fall was. That prior knows the room (its size and where the agent stands
in it), which the clip alone does not; a second distance model is told the same
(:func:`room_context`) beside the clip, so that what listening adds to it is measured.
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from fallgen.errors import InputError
from fallgen.dataset.manifest import manifest_sha256
from fallgen.perception.audio_features import AudioFeatures, relative_place

FORMAT = "fallgen-audio-model/2"
#: Distance bins (m) the scores are broken down by.
DISTANCE_BINS_M = (0.0, 2.5, 3.5, 4.5, 100.0)


def dataset_features(ds, rows: Sequence[dict]) -> AudioFeatures:
    """The feature settings for ``ds``'s clips (sample rate and length from its first row and
    clip)."""
    if not rows:
        raise ValueError("no episodes")
    shape = ds.arrays(rows[0], ("audio",))["audio"].shape
    return AudioFeatures(sample_rate=int(rows[0]["sample_rate"]), clip_samples=int(shape[-1]))


def check_features(ds, rows: Sequence[dict], features: AudioFeatures, model_path,
                   hrtf: str | None = None) -> None:
    """A one-line error (:class:`InputError`, naming the model file and the field) when
    ``ds``'s clips are not what ``features`` were made for, or were heard with another head
    than ``hrtf`` (the model's training data's, :attr:`AudioModel.hrtf`; None: not checked)."""
    if hrtf is not None and ds.hrtf is not None and ds.hrtf != hrtf:
        raise InputError(model_path, "meta.hrtf", f"the model was trained on clips heard with "
                         f"{hrtf}; {ds.root} was heard with {ds.hrtf}")
    have = dataset_features(ds, rows)
    for name in ("sample_rate", "clip_samples"):
        if getattr(have, name) != getattr(features, name):
            raise InputError(model_path, f"features.{name}",
                             f"the model was trained on clips of {features.sample_rate} Hz, "
                             f"{features.clip_samples} samples; {ds.root} has "
                             f"{have.sample_rate} Hz, {have.clip_samples} samples")


def feature_matrix(ds, rows: Sequence[dict], features: AudioFeatures,
                   progress: Callable[[int], None] | None = None) -> np.ndarray:
    """(N, F) features of the rows' clips, read shard file by shard file."""
    out = np.empty((len(rows), len(features.names)), np.float32)
    by_file: dict[str, list[int]] = defaultdict(list)
    for i, r in enumerate(rows):
        by_file[r["media_file"]].append(i)
    for name, idx in sorted(by_file.items()):
        path = Path(ds.root) / name
        if not path.is_file():
            raise InputError(path, "audio", "missing media file")
        with h5py.File(path, "r") as f:
            audio = f["audio"]
            for i in idx:
                out[i] = features.extract(audio[rows[i]["media_index"]])
                if progress is not None:
                    progress(1)
    return out


def place_targets(rows: Sequence[dict]) -> np.ndarray:
    """(N, 2): azimuth (rad) and distance (m) of each fall from its agent."""
    return np.array([relative_place(r) for r in rows], float)


@dataclass(frozen=True)
class AudioPrediction:
    categories: tuple[str, ...]  # the model's category table
    category_p: np.ndarray  # (C,) probabilities
    materials: tuple[str, ...]
    material_p: np.ndarray
    azimuth_rad: float  # counter-clockwise from the agent's heading
    distance_m: float

    @property
    def category(self) -> str:
        return self.categories[int(np.argmax(self.category_p))]

    @property
    def material(self) -> str:
        return self.materials[int(np.argmax(self.material_p))]

    @property
    def position(self) -> np.ndarray:
        """Where the fall was, in the agent's frame (x forward, y left), m."""
        return self.distance_m * np.array([math.cos(self.azimuth_rad),
                                           math.sin(self.azimuth_rad)])


@dataclass
class AudioModel:
    features: AudioFeatures
    category_model: object
    material_model: object
    #: (cos azimuth, sin azimuth) from the spatial features
    place_model: object
    #: log distance from every feature (what the object is tells how loud it was)
    distance_model: object
    #: log distance from every feature and the :func:`room_context` the room-centre prior
    #: knows (the agent's place in the room and the room's size)
    room_distance_model: object
    manifest_sha256: str = ""
    n_train: int = 0
    #: median error (m) of the position on the training set's out-of-bag predictions: the
    #: uncertainty a planner searches around the estimate
    position_error_m: float = 1.0
    meta: dict = field(default_factory=dict)

    # -- training and prediction ----------------------------------------------------------
    @staticmethod
    def train(ds, rows: Sequence[dict], seed: int = 0, trees: int = 300,
              progress: Callable[[int], None] | None = None,
              X: np.ndarray | None = None, world=None) -> AudioModel:
        """Learn from ``rows`` of ``ds`` (``X``: their :func:`feature_matrix`, when it is
        already at hand; ``world``: the dataset's world, for the rooms' sizes; None: the
        packaged one)."""
        from sklearn.ensemble import ExtraTreesClassifier, ExtraTreesRegressor
        from sklearn.model_selection import KFold, cross_val_predict
        from threadpoolctl import threadpool_limits

        if len(rows) < 2:
            raise ValueError(f"{len(rows)} training episode(s): need at least 2")
        features = dataset_features(ds, rows)
        if X is None:
            X = feature_matrix(ds, rows, features, progress)
        elif X.shape != (len(rows), len(features.names)):
            raise ValueError(f"X is {X.shape}, not ({len(rows)}, {len(features.names)})")
        place = place_targets(rows)
        Y = np.column_stack([np.cos(place[:, 0]), np.sin(place[:, 0]), np.log(place[:, 1])])
        common = dict(n_estimators=trees, random_state=seed, n_jobs=1, min_samples_leaf=1,
                      max_features="sqrt")
        cat = ExtraTreesClassifier(**common).fit(X, [r["category"] for r in rows])
        mat = ExtraTreesClassifier(**common).fit(X, [r["audio_material"] for r in rows])
        bag = {**common, "max_features": 0.5, "bootstrap": len(rows) > 2,
               "oob_score": len(rows) > 2}
        reg = ExtraTreesRegressor(**bag).fit(X[:, features.spatial], Y[:, :2])
        held = None
        with threadpool_limits(1, user_api="openmp"):  # one thread, as the trees above
            dist = distance_regressor(seed).fit(X, Y[:, 2])
            if world is None:
                from fallgen.world.library import load_world

                world = load_world()
            room_dist = distance_regressor(seed).fit(
                np.hstack([X, room_context(rows, world)]), Y[:, 2])
            if len(rows) >= 10:  # the distance's held-out predictions: 5 folds
                held = cross_val_predict(distance_regressor(seed), X, Y[:, 2],
                                         cv=KFold(5, shuffle=True, random_state=seed))
        err = 1.0
        if held is not None and hasattr(reg, "oob_prediction_"):
            oob = np.column_stack([reg.oob_prediction_, held])
            ok = np.isfinite(oob).all(axis=1)
            if ok.any():
                est = _positions(oob[ok])
                true = _positions(Y[ok])
                err = float(np.median(np.linalg.norm(est - true, axis=1)))
        return AudioModel(features, cat, mat, reg, dist, room_dist,
                          manifest_sha256(ds.root) or "", len(rows), err,
                          {"seed": seed, "trees": trees, "hrtf": ds.hrtf})

    @property
    def hrtf(self) -> str | None:
        """What its training clips were heard with (None: not recorded)."""
        return self.meta.get("hrtf")

    def predict_matrix(self, X: np.ndarray, room: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(category probabilities (N, C), material probabilities (N, M), places (N, 2):
        azimuth rad, distance m). ``room``: (N, 6) :func:`room_context` of each clip: the
        distance is then the room-told model's."""
        Y = self.place_model.predict(X[:, self.features.spatial])
        return (self.category_model.predict_proba(X), self.material_model.predict_proba(X),
                np.column_stack([azimuth(Y), self.distance_m(X, room)]))

    def distance_m(self, X: np.ndarray, room: np.ndarray | None = None) -> np.ndarray:
        """(N,) distances (m) of the falls of the feature rows ``X``: the clip's model, or with
        ``room`` ((N, 6) :func:`room_context`) the room-told one."""
        if room is None:
            return np.exp(self.distance_model.predict(X))
        return np.exp(self.room_distance_model.predict(np.hstack([X, room])))

    def predict(self, audio: np.ndarray, room: np.ndarray | None = None) -> AudioPrediction:
        """What one clip tells; ``room``: its (6,) :func:`room_context` when the listener
        knows the room (:func:`room_context_at`)."""
        cp, mp, place = self.predict_matrix(self.features.extract(audio)[None, :],
                                            None if room is None else np.reshape(room, (1, -1)))
        return AudioPrediction(tuple(self.category_model.classes_), cp[0],
                               tuple(self.material_model.classes_), mp[0],
                               float(place[0, 0]), float(place[0, 1]))

    # -- files ----------------------------------------------------------------------------
    def save(self, path: Path) -> None:
        import io

        import joblib

        from fallgen.atomic import write_bytes

        buf = io.BytesIO()
        joblib.dump({"format": FORMAT, "features": self.features.to_dict(),
                     "category_model": self.category_model,
                     "material_model": self.material_model, "place_model": self.place_model,
                     "distance_model": self.distance_model,
                     "room_distance_model": self.room_distance_model,
                     "manifest_sha256": self.manifest_sha256, "n_train": self.n_train,
                     "position_error_m": self.position_error_m, "meta": self.meta}, buf)
        write_bytes(Path(path), buf.getvalue())

    @staticmethod
    def load(path: Path) -> AudioModel:
        import joblib

        path = Path(path)
        if not path.is_file():
            raise InputError(path, "<file>", "no such model file")
        try:
            d = joblib.load(path)
        except Exception as e:  # a truncated or foreign file
            raise InputError(path, "<file>", f"not a fallgen audio model ({e})") from None
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise InputError(path, "format", f"not a {FORMAT} file")
        try:
            features = AudioFeatures.from_dict(d["features"])
        except (KeyError, TypeError) as e:
            raise InputError(path, "features", f"unreadable feature settings ({e})") from None
        if features.version != AudioFeatures().version:
            raise InputError(path, "features.version", f"made with feature version "
                             f"{features.version}; this fallgen extracts version "
                             f"{AudioFeatures().version}: train it again")
        missing = [k for k in ("category_model", "material_model", "place_model",
                               "distance_model", "room_distance_model") if k not in d]
        if missing:
            raise InputError(path, missing[0], "missing: train it again")
        return AudioModel(features, d["category_model"], d["material_model"], d["place_model"],
                          d["distance_model"], d["room_distance_model"],
                          d.get("manifest_sha256", ""),
                          int(d.get("n_train", 0)), float(d.get("position_error_m", 1.0)),
                          dict(d.get("meta", {})))


def distance_regressor(seed: int):
    """The log distance's model: histogram gradient boosting, 500 rounds at a rate of 0.05,
    leaves of at least 20 falls, L2 1.0 (chosen on the paper-size build's train split)."""
    from sklearn.ensemble import HistGradientBoostingRegressor

    return HistGradientBoostingRegressor(max_iter=500, learning_rate=0.05, min_samples_leaf=20,
                                         l2_regularization=1.0, early_stopping=False,
                                         random_state=seed)


def _xy(place: np.ndarray) -> np.ndarray:
    """(N, 2) positions in the agent's frame of (N, 2) azimuths (rad) and distances (m)."""
    return place[:, 1:2] * np.column_stack([np.cos(place[:, 0]), np.sin(place[:, 0])])


def azimuth(Y: np.ndarray) -> np.ndarray:
    """Azimuths (rad) of the place model's (N, 2+) predictions (cos azimuth, sin azimuth, ...):
    the lateral angle from the sine, the side (front or back) from the cosine's
    sign. Two ears tell the lateral angle well and front from back poorly (a spherical head
    not at all): where the trees are unsure of the side, their cosine averages toward 0, and
    ``atan2(sin, cos)`` would swing every such estimate out to +-90 degrees, however well the
    sine knew the lateral angle."""
    s = np.clip(Y[:, 1], -1.0, 1.0)
    return np.arctan2(s, np.where(Y[:, 0] >= 0, 1.0, -1.0) * np.sqrt(1.0 - s * s))


def _positions(Y: np.ndarray) -> np.ndarray:
    """:func:`_xy` of the place model's targets or predictions (cos azimuth, sin azimuth, log
    distance)."""
    return _xy(np.column_stack([azimuth(Y), np.exp(Y[:, 2])]))


# -- scores ---------------------------------------------------------------------------------------

def angle_error_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a - b| (rad in, degrees out), wrapped to 0..180."""
    return np.degrees(np.abs(np.arctan2(np.sin(a - b), np.cos(a - b))))


def _lateral_error_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Error of the lateral angle (front and back folded onto each other): what two ears tell
    apart without a pinna (the spherical head's cues are the same in front and behind)."""
    return np.degrees(np.abs(np.arcsin(np.sin(a)) - np.arcsin(np.sin(b))))


#: Sources closer than this to the interaural axis (azimuth +-90 degrees) are left out of the
#: front/back confusion rate: at the axis front and back are the same place.
FRONT_BACK_MARGIN_DEG = 15.0


def front_back_flips(est: np.ndarray, true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per source: (confused, counted). Confused: the estimated azimuth (rad) lies on the other
    side of the interaural axis (front against back: the cosine's sign) than the true one.
    Counted: the source is at least :data:`FRONT_BACK_MARGIN_DEG` from that axis (the usual
    rule of localisation studies, e.g. Wenzel et al. 1993, which leave out a cone about the
    axis where a reversal is not defined)."""
    counted = np.abs(np.cos(true)) >= math.sin(math.radians(FRONT_BACK_MARGIN_DEG))
    return np.sign(np.cos(est)) != np.sign(np.cos(true)), counted


def front_back_confusions(est: np.ndarray, true: np.ndarray) -> tuple[int, int]:
    """(confusions, sources counted) of :func:`front_back_flips`."""
    wrong, counted = front_back_flips(est, true)
    return int((wrong & counted).sum()), int(counted.sum())


def _front_back_rate(est: np.ndarray, true: np.ndarray) -> float:
    wrong, n = front_back_confusions(est, true)
    return wrong / n if n else float("nan")


def _topk(p: np.ndarray, classes: Sequence[str], truth: Sequence[str], k: int) -> float:
    order = np.argsort(-p, axis=1)[:, :k]
    names = np.asarray(classes)[order]
    return float(np.mean([t in row for t, row in zip(truth, names)]))


def _spearman(a: np.ndarray, b: np.ndarray) -> float:
    from scipy.stats import spearmanr

    if len(a) < 3 or np.ptp(a) == 0 or np.ptp(b) == 0:
        return float("nan")
    return float(spearmanr(a, b).statistic)


#: room variants with fewer test falls than this are left out of the within-room correlation
WITHIN_ROOM_MIN = 5


def _within_room(rows: Sequence[dict], est: np.ndarray, true: np.ndarray) -> float:
    """The mean over room variants (those with :data:`WITHIN_ROOM_MIN` falls or more) of the
    rank correlation of ``est`` with ``true`` distances: how well the estimate orders the falls
    of one room, where the room's size, which a prior knowing the room already tells, is
    the same for all (nan when no variant has enough)."""
    groups: dict[str, list[int]] = defaultdict(list)
    for i, r in enumerate(rows):
        groups[r["room_variant"]].append(i)
    rho = [_spearman(est[k], true[k]) for k in groups.values() if len(k) >= WITHIN_ROOM_MIN]
    rho = [r for r in rho if np.isfinite(r)]
    return float(np.mean(rho)) if rho else float("nan")


def room_context_at(size_m: Sequence[float], agent_xy: Sequence[float],
                    heading_rad: float) -> np.ndarray:
    """(6,) what the room-centre prior knows of a listener in a room of ``size_m`` (x, y,
    ...; its corner at the origin) standing at ``agent_xy`` facing ``heading_rad``: the
    distance to the room's centre, the cosine and sine of its azimuth from the heading, the
    room's two sides and its floor area."""
    lx, ly = float(size_m[0]), float(size_m[1])
    dx, dy = lx / 2 - float(agent_xy[0]), ly / 2 - float(agent_xy[1])
    az = math.atan2(dy, dx) - heading_rad
    return np.array([math.hypot(dx, dy), math.cos(az), math.sin(az), lx, ly, lx * ly])


def room_context(rows: Sequence[dict], world) -> np.ndarray:
    """(N, 6) :func:`room_context_at` of each row's spawn in its room variant."""
    return np.array([room_context_at(world.variant(r["room_variant"]).size_m,
                                     (r["spawn_x"], r["spawn_y"]), r["spawn_yaw_rad"])
                     for r in rows], float).reshape(len(rows), 6)


def room_centre_prior(rows: Sequence[dict], world,
                      context: np.ndarray | None = None) -> np.ndarray:
    """(N, 2) azimuth and distance of each room's centre from the agent: where a planner
    without audio would guess the fall was (read off the rows' :func:`room_context`,
    ``context`` when it is at hand)."""
    c = room_context(rows, world) if context is None else context
    return np.array([[math.atan2(sin, cos), d] for d, cos, sin in c[:, :3]],
                    float).reshape(len(rows), 2)


def evaluate(model: AudioModel, ds, rows: Sequence[dict], train_rows: Sequence[dict],
             world, progress: Callable[[int], None] | None = None,
             X: np.ndarray | None = None
             ) -> tuple[dict, dict[str, tuple[np.ndarray, tuple[str, ...]]]]:
    """Scores of ``model`` on ``rows`` and of the no-audio prior (from ``train_rows``), by
    zone kind and by distance too; and the confusion matrices (rows: truth) by name. ``X``:
    the rows' feature matrix, when it is already at hand."""
    if X is None:
        X = feature_matrix(ds, rows, model.features, progress)
    cp, mp, place = model.predict_matrix(X)
    cats, mats = list(model.category_model.classes_), list(model.material_model.classes_)
    truth_c = [r["category"] for r in rows]
    truth_m = [r["audio_material"] for r in rows]
    true_place = place_targets(rows)
    az_err = angle_error_deg(place[:, 0], true_place[:, 0])
    lat_err = _lateral_error_deg(place[:, 0], true_place[:, 0])
    pos_err = np.linalg.norm(_xy(place) - _xy(true_place), axis=1)
    freq_c = [c for c, _ in Counter(r["category"] for r in train_rows).most_common()]
    freq_m = [m for m, _ in Counter(r["audio_material"] for r in train_rows).most_common()]
    room = room_context(rows, world)
    prior = room_centre_prior(rows, world, room)
    prior_az = angle_error_deg(prior[:, 0], true_place[:, 0])
    told = model.distance_m(X, room)
    prior_rho = _spearman(prior[:, 1], true_place[:, 1])
    prior_within = _within_room(rows, prior[:, 1], true_place[:, 1])
    scores = {
        "episodes": len(rows),
        "category_top1": _topk(cp, cats, truth_c, 1),
        "category_top5": _topk(cp, cats, truth_c, 5),
        "material_top1": _topk(mp, mats, truth_m, 1),
        "azimuth_median_error_deg": float(np.median(az_err)),
        "lateral_median_error_deg": float(np.median(lat_err)),
        "front_back_confusion_rate": _front_back_rate(place[:, 0], true_place[:, 0]),
        "distance_rank_correlation": _spearman(place[:, 1], true_place[:, 1]),
        "distance_rank_correlation_within_room": _within_room(rows, place[:, 1],
                                                              true_place[:, 1]),
        # told what the prior knows (the agent's place in the room, the room's size)
        "distance_rank_correlation_told_room": _spearman(told, true_place[:, 1]),
        "distance_rank_correlation_within_room_told_room": _within_room(rows, told,
                                                                        true_place[:, 1]),
        "position_median_error_m": float(np.median(pos_err)),
        "chance": {"category_top1": 1 / max(len(cats), 1), "category_top5":
                   min(5, len(cats)) / max(len(cats), 1), "material_top1": 1 / max(len(mats), 1),
                   "azimuth_median_error_deg": 90.0, "lateral_median_error_deg": 30.0,
                   "front_back_confusion_rate": 0.5},
        "prior": {
            "category_top1": float(np.mean([t in freq_c[:1] for t in truth_c])),
            "category_top5": float(np.mean([t in freq_c[:5] for t in truth_c])),
            "material_top1": float(np.mean([t in freq_m[:1] for t in truth_m])),
            "azimuth_median_error_deg": float(np.median(prior_az)),
            "lateral_median_error_deg": float(np.median(_lateral_error_deg(
                prior[:, 0], true_place[:, 0]))),
            "front_back_confusion_rate": _front_back_rate(prior[:, 0], true_place[:, 0]),
            "distance_rank_correlation": prior_rho,
            "distance_rank_correlation_within_room": prior_within,
            "distance_rank_correlation_told_room": prior_rho,
            "distance_rank_correlation_within_room_told_room": prior_within,
        },
    }
    top1 = np.asarray(cats)[np.argmax(cp, axis=1)] == np.asarray(truth_c)
    by_zone: dict[str, dict] = {}
    for z in sorted({r["zone_kind"] for r in rows}):
        k = np.array([r["zone_kind"] == z for r in rows])
        by_zone[z] = {"episodes": int(k.sum()), "category_top1": float(top1[k].mean()),
                      "azimuth_median_error_deg": float(np.median(az_err[k]))}
    by_room_kind: dict[str, dict] = {}
    for kind in sorted({r["room_kind"] for r in rows}):
        k = np.array([r["room_kind"] == kind for r in rows])
        by_room_kind[kind] = {
            "episodes": int(k.sum()), "category_top1": float(top1[k].mean()),
            "azimuth_median_error_deg": float(np.median(az_err[k])),
            "lateral_median_error_deg": float(np.median(lat_err[k])),
            "front_back_confusion_rate": _front_back_rate(place[k, 0], true_place[k, 0])}
    by_distance: dict[str, dict] = {}
    for lo, hi in zip(DISTANCE_BINS_M[:-1], DISTANCE_BINS_M[1:]):
        k = (true_place[:, 1] >= lo) & (true_place[:, 1] < hi)
        if k.any():
            by_distance[f"{lo:g}-{hi:g} m"] = {
                "episodes": int(k.sum()), "category_top1": float(top1[k].mean()),
                "azimuth_median_error_deg": float(np.median(az_err[k]))}
    scores["by_zone_kind"] = by_zone
    scores["by_room_kind"] = by_room_kind
    scores["by_distance"] = by_distance
    confusion = {"category": _confusion(truth_c, np.asarray(cats)[np.argmax(cp, axis=1)], cats),
                 "material": _confusion(truth_m, np.asarray(mats)[np.argmax(mp, axis=1)], mats)}
    return scores, confusion


def _confusion(truth: Sequence[str], pred: Sequence[str], labels: Sequence[str]
               ) -> tuple[np.ndarray, tuple[str, ...]]:
    """(counts with the truth as rows, the labels in order)."""
    labels = sorted(set(labels) | set(truth))
    index = {n: i for i, n in enumerate(labels)}
    m = np.zeros((len(labels), len(labels)), int)
    for t, p in zip(truth, pred):
        m[index[t], index[p]] += 1
    return m, tuple(labels)


def confusion_png(matrix: np.ndarray, labels: Sequence[str], title: str, path: Path) -> Path:
    """A row-normalised confusion matrix (rows: the truth) as a PNG, darker for more."""
    import cv2

    from fallgen.world.preview import write_png

    n = len(labels)
    cell, left, top = 18, 150, 60
    img = np.full((top + n * cell + 20, left + n * cell + 20, 3), 255, np.uint8)
    norm = matrix / np.maximum(matrix.sum(axis=1, keepdims=True), 1)
    for i in range(n):
        for j in range(n):
            v = int(round(255 * (1 - norm[i, j])))
            colour = (255, v, v) if i != j else (v, 200 + v * 55 // 255, v)  # RGB
            y0, x0 = top + i * cell, left + j * cell
            img[y0:y0 + cell - 1, x0:x0 + cell - 1] = colour
        cv2.putText(img, str(labels[i])[:20], (4, top + i * cell + 13), cv2.FONT_HERSHEY_SIMPLEX,
                    0.38, (20, 20, 20), 1, cv2.LINE_AA)
    accuracy = np.trace(matrix) / max(matrix.sum(), 1)
    cv2.putText(img, f"{title}: rows truth, columns predicted; accuracy {accuracy:.2f}",
                (4, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    return write_png(img, path)
