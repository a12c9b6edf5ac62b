# Two entry points that work on a fresh machine: `make demo` and `make test`.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint clean

$(STAMP): pyproject.toml setup.py
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[dev,train,distributed]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/lookahead demo --out out/demo

test: $(STAMP)
	bash setup/system.sh
	$(BIN)/ruff check .
	$(BIN)/lint-imports
	$(BIN)/lookahead regress scenarios/suites/smoke.yaml --baseline scenarios/suites/smoke.baseline.json
	$(BIN)/lookahead regress scenarios/suites/smoke.yaml --aeb on --detector onnx --render \
		--baseline scenarios/suites/smoke_aeb_pixels.baseline.json
	$(BIN)/lookahead regress scenarios/suites/cooperative.yaml --baseline scenarios/suites/cooperative.baseline.json
	LOOKAHEAD_REQUIRE_SYSTEM=1 $(BIN)/python -m pytest

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/lint-imports

clean:
	rm -rf $(VENV) out .pytest_cache .cache
