"""Build configurations (``configs/*.toml``): typed, validated, with one-line errors."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fallgen.audio.ambient import DEFAULT_NOISE_DB_A
from fallgen.errors import InputError
from fallgen.fields import Fields, load_toml
from fallgen.physics.settle import SettleCriteria


@dataclass(frozen=True)
class RehearseConfig:
    rooms: str = "*"
    zones: str = "*"  # glob over zone ids (z00..z19), e.g. "z0[0-4]" for quick builds
    events_per_zone: int = 8
    max_trials_per_zone: int = 60
    drop_height_m: tuple[float, float] = (1.5, 2.8)
    #: every kept event falls at least this far before its first impact (a zone under a
    #: cover too low for that is reached by a fall beside it, thrown in)
    min_fall_m: float = 0.3
    push_speed_mps: float = 0.15
    spin_radps: float = 2.0
    #: from the flat keys settle_lin_mps, settle_ang_radps, settle_hold_s, timeout_s
    settle: SettleCriteria = SettleCriteria()


#: Split names in their order of episode ids.
SPLITS = ("train", "validation", "test")


@dataclass(frozen=True)
class GenerateConfig:
    #: episodes per split (train, validation, test)
    episodes: tuple[int, int, int] = (6000, 1000, 1000)
    frames: str = "first"  # "first" or "trajectory"
    #: the head heard with: "sadie_ku100" (measured, packaged), "sphere" (the spherical-head
    #: model) or a SOFA file (fallgen.audio.heads)
    hrtf: str = "sadie_ku100"
    audio_s: float = 2.0
    image_source_order: int = 6
    episodes_per_shard: int = 500
    #: the ambient noise floor at the ears, dB(A) (fallgen.audio.ambient); 0: none
    ambient_noise_db_a: float = DEFAULT_NOISE_DB_A
    #: a fall heard more quietly than this at the agent (peak, dB SPL) starts no episode: the
    #: episode takes its next event (skip reason "inaudible"); 0 keeps every fall
    min_heard_peak_db_spl: float = 35.0
    #: draw the views with textures and a shadow-casting light (world.scene.LOOK); false:
    #: flat colours (cheaper to render: docs/rendering.md)
    appearance: bool = True
    #: draw every episode's views with a look of its own (textures, colours, light: world.look),
    #: from the episode's seed; needs appearance. Off: every episode of a room looks the same
    appearance_randomization: bool = False


@dataclass(frozen=True)
class BuildConfig:
    root_seed: int
    out: Path
    rehearse: RehearseConfig
    file: Path
    generate: GenerateConfig = GenerateConfig()


#: the keys of each table, checked before any is read (an unknown key is named as unknown,
#: not as the required key it displaced)
BUILD_KEYS = ("root_seed", "out")
REHEARSE_KEYS = ("rooms", "zones", "events_per_zone", "max_trials_per_zone", "drop_height_m",
                 "min_fall_m", "push_speed_mps", "spin_radps", "settle_lin_mps",
                 "settle_ang_radps", "settle_hold_s", "timeout_s")
GENERATE_KEYS = ("episodes", "frames", "hrtf", "audio_s", "image_source_order",
                 "episodes_per_shard", "ambient_noise_db_a", "min_heard_peak_db_spl",
                 "appearance", "appearance_randomization")
#: seeds are 64-bit signed integers in the dataset (the ``root_seed`` column)
MAX_SEED = 2 ** 63 - 1
#: what marks a directory as a source tree, not a place for a dataset
SOURCE_MARKERS = ("pyproject.toml", "setup.py", "setup.cfg", ".git")
#: how a dataset card fallgen writes begins (its front matter's first lines)
CARD_HEAD = ("---", "pretty_name: Fallen Objects (fallgen)")


def is_card(path: Path) -> bool:
    """``path`` is a dataset card fallgen wrote."""
    head = "\n".join(CARD_HEAD).encode()
    try:
        with open(path, "rb") as f:
            return f.read(len(head)) == head
    except OSError:
        return False


def check_out(out: str | Path, file: str | Path = "<command line>",
              key: str = "--out") -> Path:
    """``out`` as a dataset directory, or an InputError: not empty (the current directory),
    not a file, not a source tree (a directory holding pyproject.toml, setup.py or .git),
    not a directory whose README.md is not a dataset card (the card would overwrite it)."""
    if not str(out).strip():
        raise InputError(file, key, "empty (that would build into the current directory); "
                         "give a directory of its own, e.g. build/NAME")
    p = Path(out)
    if p.exists() and not p.is_dir():
        raise InputError(file, key, f"{p} is a file, not a directory")
    if p.is_dir():
        for m in SOURCE_MARKERS:
            if (p / m).exists():
                raise InputError(file, key, f"{p} holds {m}: a source tree, not a dataset "
                                 "directory; build into a directory of its own, e.g. build/NAME")
        card = p / "README.md"
        if card.is_file():
            if not is_card(card):
                raise InputError(file, key, f"{card} is not a fallgen dataset card (the build "
                                 "would overwrite it); build into a directory of its own")
    return p


def _rehearse(f: Fields) -> RehearseConfig:
    f.reject_unknown(REHEARSE_KEYS)
    r = RehearseConfig(
        rooms=f.str("rooms"),
        zones=f.str("zones", "*"),
        events_per_zone=f.int("events_per_zone", lo=1, hi=1000),
        max_trials_per_zone=f.int("max_trials_per_zone", lo=1, hi=100000),
        drop_height_m=f.floats("drop_height_m", n=2, lo=0.05, hi=6.0, increasing=True),
        min_fall_m=f.float("min_fall_m", lo=0.0, hi=3.0),
        push_speed_mps=f.float("push_speed_mps", lo=0.0, hi=5.0),
        spin_radps=f.float("spin_radps", lo=0.0, hi=50.0),
        settle=SettleCriteria(
            lin_tol_mps=f.float("settle_lin_mps", positive=True, hi=1.0),
            ang_tol_radps=f.float("settle_ang_radps", positive=True, hi=10.0),
            hold_s=f.float("settle_hold_s", positive=True, hi=5.0),
            timeout_s=f.float("timeout_s", positive=True, hi=60.0),
        ),
    )
    if r.max_trials_per_zone < r.events_per_zone:
        raise f.error("max_trials_per_zone", "must be at least events_per_zone")
    f.reject_unknown()
    return r


def _generate(f: Fields) -> GenerateConfig:
    f.reject_unknown(GENERATE_KEYS)
    e = f.table("episodes")
    e.reject_unknown(SPLITS)
    counts = tuple(e.int(s, lo=0, hi=10_000_000) for s in SPLITS)
    g = GenerateConfig(
        episodes=counts,  # type: ignore[arg-type]
        frames=f.str("frames", choices=("first", "trajectory")),
        hrtf=f.str("hrtf"),
        audio_s=f.float("audio_s", positive=True, hi=30.0),
        image_source_order=f.int("image_source_order", lo=0, hi=30),
        episodes_per_shard=f.int("episodes_per_shard", lo=1, hi=100_000),
        ambient_noise_db_a=f.float("ambient_noise_db_a", lo=0.0, hi=80.0),
        min_heard_peak_db_spl=f.float("min_heard_peak_db_spl", lo=0.0, hi=120.0),
        appearance=f.bool("appearance", True),
        appearance_randomization=f.bool("appearance_randomization", False),
    )
    if g.appearance_randomization and not g.appearance:
        raise f.error("appearance_randomization", "needs appearance = true (a look is drawn on "
                      "textured views)")
    if sum(g.episodes) == 0:
        raise e.error(SPLITS[0], "at least one episode is needed")
    if g.hrtf not in ("sadie_ku100", "sphere") and not Path(g.hrtf).is_file():
        raise f.error("hrtf", f"{g.hrtf!r}: not \"sadie_ku100\" (the measured head), "
                      "\"sphere\" (the spherical-head model) nor a SOFA file")
    f.reject_unknown()
    return g


def load_config(path: str | Path) -> BuildConfig:
    """Load and validate a build config; every field is required (no silent defaults)."""
    try:
        Path(path).read_bytes().decode("utf-8")
    except UnicodeDecodeError as e:
        raise InputError(path, "<file>", f"not UTF-8 text (byte {e.start}); save the config "
                         "as UTF-8") from None
    except OSError:
        pass  # load_toml names it
    f = load_toml(path)
    f.reject_unknown(("build", "rehearse", "generate"))
    b = f.table("build")
    b.reject_unknown(BUILD_KEYS)
    root_seed = b.int("root_seed", lo=0, hi=MAX_SEED)
    out = check_out(b.str("out"), path, "build.out")
    b.reject_unknown()
    cfg = BuildConfig(root_seed, out, _rehearse(f.table("rehearse")), Path(path),
                      _generate(f.table("generate")))
    f.reject_unknown()
    return cfg
