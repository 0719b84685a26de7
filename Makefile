# mimika — the two commands a user needs:
#   make demo   installs everything, then runs the main job on the built-in head
#   make test   installs everything, then runs lint + the test suite
VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= out

.PHONY: setup demo test lint bench clean

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml scripts/setup.sh
	bash scripts/setup.sh $(VENV)
	touch $@

demo: setup
	$(BIN)/mimika pose --grid -o $(OUT)/au-sheet.png
	$(BIN)/mimika pose --au AU06=0.8 --au AU12=1 --au AU25=0.4 --view three-quarter -o $(OUT)/smile.png
	@echo "demo: wrote $(OUT)/au-sheet.png and $(OUT)/smile.png"

test: setup
	bash scripts/setup-node.sh
	bash scripts/setup-studio.sh
	bash scripts/setup-browser.sh
	$(BIN)/ruff check src tests bench
	$(BIN)/python -m pytest -q

bench: setup
	$(BIN)/python bench/bench_rig.py
	$(BIN)/python bench/bench_render.py

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
