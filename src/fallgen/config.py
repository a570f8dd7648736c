"""Build configurations (``configs/*.toml``): typed, validated, with one-line errors."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

from fallgen.fields import Fields, load_toml


@dataclass(frozen=True)
class RehearseConfig:
    rooms: str = "*"
    zones: str = "*"  # glob over zone ids (z00..z19), e.g. "z0[0-4]" for quick builds
    events_per_zone: int = 8
    max_trials_per_zone: int = 60
    drop_height_m: tuple[float, float] = (1.5, 2.8)
    push_speed_mps: float = 0.15
    spin_radps: float = 2.0
    settle_lin_mps: float = 0.01
    settle_ang_radps: float = 0.1
    settle_hold_s: float = 0.25
    timeout_s: float = 6.0


@dataclass(frozen=True)
class BuildConfig:
    root_seed: int
    out: Path
    rehearse: RehearseConfig
    file: Path

    def as_dict(self) -> dict:
        d = asdict(self)
        d["out"], d["file"] = str(self.out), str(self.file)
        return d


def _rehearse(f: Fields) -> RehearseConfig:
    r = RehearseConfig(
        rooms=f.str("rooms"),
        zones=f.str("zones", "*"),
        events_per_zone=f.int("events_per_zone", lo=1, hi=1000),
        max_trials_per_zone=f.int("max_trials_per_zone", lo=1, hi=100000),
        drop_height_m=f.floats("drop_height_m", n=2, lo=0.05, hi=6.0, increasing=True),
        push_speed_mps=f.float("push_speed_mps", lo=0.0, hi=5.0),
        spin_radps=f.float("spin_radps", lo=0.0, hi=50.0),
        settle_lin_mps=f.float("settle_lin_mps", positive=True, hi=1.0),
        settle_ang_radps=f.float("settle_ang_radps", positive=True, hi=10.0),
        settle_hold_s=f.float("settle_hold_s", positive=True, hi=5.0),
        timeout_s=f.float("timeout_s", positive=True, hi=60.0),
    )
    if r.max_trials_per_zone < r.events_per_zone:
        raise f.error("max_trials_per_zone", "must be at least events_per_zone")
    f.reject_unknown()
    return r


def load_config(path: str | Path) -> BuildConfig:
    """Load and validate a build config; every field is required (no silent defaults)."""
    f = load_toml(path)
    b = f.table("build")
    root_seed = b.int("root_seed", lo=0)
    out = Path(b.str("out"))
    b.reject_unknown()
    cfg = BuildConfig(root_seed, out, _rehearse(f.table("rehearse")), Path(path))
    f.reject_unknown()
    return cfg
