# rfp-twin: `make demo`, `make test`, `make bench`. Each creates .venv on first use.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEMO_OUT ?= out/demo

.PHONY: demo test bench sysdeps clean kaiju-env kaiju-check kaiju-bench kaiju-production

# System packages: python3-venv, and Mesa's EGL / OSMesa / GL libraries for offscreen
# MuJoCo rendering. Installed only when missing (needs root, as on the project machines).
SYS_LIBS := libEGL.so.1:libegl1 libOSMesa.so.8:libosmesa6 libGL.so.1:libgl1
sysdeps:
	@missing=""; \
	$(PY) -c "import venv, ensurepip" 2>/dev/null || missing="python3-venv"; \
	for pair in $(SYS_LIBS); do lib=$${pair%%:*}; pkg=$${pair##*:}; \
	  ldconfig -p | grep -q "$$lib" || missing="$$missing $$pkg"; done; \
	if [ -n "$$missing" ]; then echo "installing:$$missing"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing; fi

$(STAMP): pyproject.toml | sysdeps
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[dev]'
	$(BIN)/python -m compileall -q models planners validation twin
	touch $(STAMP)

demo: $(STAMP)
	rm -rf $(DEMO_OUT)
	$(BIN)/rfp-twin plan --preset sdss-v --out $(DEMO_OUT) --seed 1
	$(BIN)/rfp-twin validate $(DEMO_OUT)
	$(BIN)/rfp-twin simulate $(DEMO_OUT)
	$(BIN)/rfp-twin render $(DEMO_OUT) --out $(DEMO_OUT)/fold.mp4 --speedup 2
	$(BIN)/rfp-twin record $(DEMO_OUT) --out $(DEMO_OUT)/run.rrd

test: $(STAMP)
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_planner.py
	$(BIN)/python benchmarks/bench_fold_duration.py --no-planners
	$(BIN)/python benchmarks/bench_sim.py
	$(BIN)/python benchmarks/bench_render.py
	$(BIN)/python benchmarks/bench_postprocess.py --only backends --preset sdss-v

# Optional cross-check against kaiju (SDSS-V's planner), never part of `make test`: a side
# environment .venv-kaiju (numpy < 2) with sdss-kaiju from a wheel folder (KAIJU_WHEELS,
# e.g. ../shared/wheels) or, without it, from the package index (its sdist needs network).
KAIJU_VENV ?= .venv-kaiju
KAIJU_WHEELS ?=
KAIJU_SEEDS ?= 1-20
KAIJU_INSTRUMENTS ?= apo,lco,curved
KAIJU_ALGORITHMS ?= greedy,markov
kaiju-env:
	KAIJU_WHEELS=$(KAIJU_WHEELS) benchmarks/kaiju/setup_env.sh $(KAIJU_VENV)

kaiju-check: $(STAMP) kaiju-env
	KAIJU_PYTHON=$(KAIJU_VENV)/bin/python $(BIN)/python benchmarks/kaiju/crosscheck.py --matrix \
	  --seeds $(KAIJU_SEEDS) --instruments $(KAIJU_INSTRUMENTS) --algorithms $(KAIJU_ALGORITHMS) \
	  --work out/kaiju-runs --out out/kaiju-check.json

kaiju-bench: $(STAMP) kaiju-env
	KAIJU_PYTHON=$(KAIJU_VENV)/bin/python $(BIN)/python benchmarks/kaiju/bench_vs_kaiju.py

# The production question: kaiju's jaeger flow (MDP2 + getPathPair) against ours, same targets.
kaiju-production: $(STAMP) kaiju-env
	for i in apo lco; do \
	  KAIJU_PYTHON=$(KAIJU_VENV)/bin/python $(BIN)/python benchmarks/kaiju/bench_production_kaiju.py kaiju --instrument $$i --seeds 1-50; \
	  KAIJU_PYTHON=$(KAIJU_VENV)/bin/python $(BIN)/python benchmarks/kaiju/bench_production_kaiju.py ours --instrument $$i --seeds 1-50; \
	done
	$(BIN)/python benchmarks/kaiju/bench_production_kaiju.py report --figure benchmarks/figures/production_vs_kaiju.png

clean:
	rm -rf $(VENV) out .pytest_cache
