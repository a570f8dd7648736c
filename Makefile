# fallgen: the two commands a new user needs are `make demo` and `make test`; each sets itself up.
SHELL := /bin/bash
# a failing benchmark piped into tee fails its target
.SHELLFLAGS := -o pipefail -c
VENV ?= .venv
PY := $(VENV)/bin/python
FALLGEN := $(VENV)/bin/fallgen
export MUJOCO_GL ?= egl
CONFIG ?= configs/full.toml
WORKERS ?= $(shell nproc 2>/dev/null || echo 2)

.PHONY: setup demo test test-fast bench bench-full loudness hrtf table report assets rehearse generate dataset smoke clean lint

setup: $(VENV)/.fallgen-installed
$(VENV)/.fallgen-installed: pyproject.toml scripts/setup.sh
	@VENV=$(VENV) scripts/setup.sh

## demo: every room variant checked and drawn, one exported to MJCF, the object catalogue drawn,
## one room rehearsed, three falls' sounds, 8 episodes generated, validated, summarised and one
## drawn; from scratch each time (demo/ is made again).
demo: setup
	rm -rf demo
	$(FALLGEN) rooms check
	$(FALLGEN) rooms show '*-m1' -o demo/rooms
	$(FALLGEN) rooms export kitchen_galley-l1-m1 -o demo/kitchen_galley-l1-m1.xml
	$(FALLGEN) objects list
	$(FALLGEN) objects show -o demo/objects.png
	$(FALLGEN) rehearse --config configs/demo.toml
	$(FALLGEN) sounds demo/rehearsal/kitchen_galley-l1-m1.parquet -o demo/sounds --limit 3 --binaural
	$(FALLGEN) generate --config configs/demo.toml
	$(FALLGEN) validate demo
	$(FALLGEN) stats demo
	$(FALLGEN) show demo 0 -o demo/episode-0.png --wav demo/episode-0.wav
	@echo "demo: room plans in demo/rooms/, objects in demo/objects.png, fall events in demo/rehearsal/, fall sounds in demo/sounds/ (dry: WAV in Pa at 1 m; *.binaural.wav: heard at the room centre, pressure / 20 Pa; spectrograms), 8 episodes in demo/data (Parquet) + demo/media (HDF5) with demo/README.md (card) and demo/manifest.json, episode 0 drawn in demo/episode-0.png (+ .wav), MJCF in demo/ (python -m mujoco.viewer --mjcf=demo/kitchen_galley-l1-m1.xml)"

test: setup
	$(PY) -m pytest -q -n 2 --dist loadgroup

test-fast: setup
	$(PY) -m pytest -q -n 2 --dist loadgroup -m "not slow"

bench: setup
	@mkdir -p build
	$(PY) bench/rehearse_bench.py | tee build/bench-rehearse.json
	bash ../shared/peers/setup.sh pyimpact > build/peers.env || true
	$(PY) bench/impact_bench.py $$(sed -n 's/^pyimpact=/--pyimpact /p' build/peers.env) \
		| tee build/bench-impact.json
	bash ../shared/peers/setup.sh pyroomacoustics > build/peers-room.env || true
	$(PY) bench/room_bench.py \
		$$(sed -n 's/^pyroomacoustics=/--pyroomacoustics /p' build/peers-room.env) \
		| tee build/bench-room.json
	$(PY) bench/generate_bench.py | tee build/bench-generate.json
	$(PY) bench/build_bench.py | tee build/bench-build.json
	$(PY) bench/env_bench.py --dataset build/smoke | tee build/bench-env.json
	$(PY) bench/appearance.py | tee build/bench-appearance.json
	$(PY) bench/report.py build
	$(PY) bench/provenance.py build/bench.json make bench

## loudness: the floors under the ISO tapping machine (vs EN ISO 12354-2 and measured coverings),
## then the dry peak and Leq at 1 m of reference drops onto five floors (docs/physics.md's
## calibration tables; build/loudness.json), a few minutes.
loudness: setup
	@mkdir -p build
	$(PY) bench/loudness_table.py --json build/loudness.json
	$(PY) bench/provenance.py build/loudness.json make loudness

## bench-full: the paper-size build itself, timed (wall per phase, CPU, each worker's peak
## memory, file fingerprint), validated, then its generation again with one worker (the
## speed-up), and removed; ~20-30 min on 2 cores, ~12 GB of disk.
bench-full: setup
	@mkdir -p build
	$(PY) bench/full_build.py --workers $(WORKERS) --one-worker | tee build/bench-full.json
	$(PY) bench/provenance.py build/bench-full.json make bench-full
	$(PY) bench/report.py build

## hrtf: the audio module on two builds that differ only in the head (the measured SADIE KU100
## and the spherical model): azimuth error and front/back confusions side by side,
## build/hrtf.json; ~30 min on 2 cores, ~4 GB of disk under build/hrtf.
hrtf: setup
	@mkdir -p build
	$(PY) bench/hrtf_compare.py --workers $(WORKERS) --json build/hrtf.json > /dev/null
	$(PY) bench/provenance.py build/hrtf.json make hrtf

## table: the paper's Table 1 and Table 2 on the paper-size build (made first when missing),
## with the learned audio module: build/table/table.md. TABLE_EPISODES per Table 1 row and
## TABLE_CROSS per room kind in Table 2 (0: every test episode). TABLE_POLICIES: trained runs
## to score in Table 1, e.g. "dt=runs/dt ppo=runs/ppo savi=runs/savi" (fallgen train).
TABLE_DATASET ?= build/full
TABLE_EPISODES ?= 300
TABLE_CROSS ?= 200
TABLE_POLICIES ?=
table: setup
	@test -f $(TABLE_DATASET)/manifest.json || $(MAKE) dataset
	$(FALLGEN) table $(TABLE_DATASET) -o build/table --episodes $(TABLE_EPISODES) \
		--cross-episodes $(TABLE_CROSS) --workers $(WORKERS) \
		$(foreach p,$(TABLE_POLICIES),--policy $(p))
	$(PY) bench/provenance.py build/table/table.json make table TABLE_DATASET=$(TABLE_DATASET) \
		TABLE_EPISODES=$(TABLE_EPISODES) TABLE_CROSS=$(TABLE_CROSS) \
		TABLE_POLICIES="$(TABLE_POLICIES)"

## report: the figures of README.md and docs/*.md made again from the JSON the targets above
## wrote (build/bench.json, bench-full.json, loudness.json, full-stats.json, table/table.json),
## each with its date, machine and command; a block whose JSON is absent is kept.
report: setup
	$(PY) bench/docs_report.py --build build

assets: setup
	$(FALLGEN) assets modes --workers $(WORKERS)

rehearse: setup
	$(FALLGEN) rehearse --config $(CONFIG) --workers $(WORKERS)

generate: setup
	$(FALLGEN) generate --config $(CONFIG) --workers $(WORKERS)

## dataset: the paper-size build (64 room variants, 8000 episodes) from scratch, then validated.
## Reruns resume. Many machines: docs/dataset.md (--shard-index/--num-shards, fallgen finalize).
dataset: setup
	$(FALLGEN) build --config configs/full.toml --workers $(WORKERS)
	$(FALLGEN) validate build/full
	$(FALLGEN) stats build/full --json build/full-stats.json
	$(PY) bench/provenance.py build/full-stats.json make dataset

## smoke: a tiny build (two rooms, 24 episodes), validated; CI runs it besides the tests.
smoke: setup
	rm -rf build/smoke  # a check from scratch (an older build's rehearsal would be refused)
	$(FALLGEN) build --config configs/smoke.toml --workers $(WORKERS)
	$(FALLGEN) validate build/smoke
	$(FALLGEN) stats build/smoke

lint: setup
	$(PY) -m ruff check src tests || true

clean:
	rm -rf demo build .pytest_cache
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
