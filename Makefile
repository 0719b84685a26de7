# mimika — the two commands a user needs:
#   make demo   installs everything, then runs the main job on the default character
#   make test   installs everything, then runs lint + the test suite
VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= out

.PHONY: setup demo test lint bench fuzz judge clean

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml scripts/setup.sh
	bash scripts/setup.sh $(VENV)
	touch $@

demo: setup
	$(BIN)/mimika news --example en -o $(OUT)/news.mp4

test: setup
	bash scripts/setup-node.sh
	bash scripts/setup-studio.sh
	bash scripts/setup-browser.sh
	bash scripts/setup-blender.sh
	$(BIN)/ruff check src tests bench
	$(BIN)/python -m pytest -q

bench: setup
	$(BIN)/python bench/bench_rig.py
	$(BIN)/python bench/bench_render.py

judge: setup  # the expressions shown to an emotion recogniser, per head × view (bench/)
	bash scripts/setup-judge.sh
	$(BIN)/python bench/expression_judge.py
	$(BIN)/python bench/au_calibration.py
	$(BIN)/python bench/lip_opening.py

fuzz: setup  # ≥ 100 000 hostile inputs to every reader: 0 crashes, 0 hangs (bench/fuzz.py)
	$(BIN)/python bench/fuzz.py --cases 100000

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
