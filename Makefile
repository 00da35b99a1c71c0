# `make demo` and `make test` each set everything up on a fresh machine.
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.bootstrapped
SCENE  ?= scenes/still-life/scene.xml
OUT    ?= out

.PHONY: setup demo test test-slow benchmark eval eval-full clean

$(STAMP): pyproject.toml scripts/bootstrap.sh
	VENV=$(VENV) scripts/bootstrap.sh

setup: $(STAMP)

demo: $(STAMP)
	@mkdir -p $(OUT)
	$(PY) render_and_complete.py $(SCENE) --rate 0.3 --out $(OUT)/demo.exr
	@echo "demo: wrote $(OUT)/demo.exr (layers), $(OUT)/demo.png (preview), $(OUT)/demo.json (record)"

test: $(STAMP)
	$(PY) -m pytest -q

test-slow: $(STAMP)
	$(PY) -m pytest -q -m slow

benchmark: $(STAMP)
	$(PY) benchmarks/render_cost.py

# docs/results.md, docs/*.png and the README's results section (references are rendered once, then cached)
eval: $(STAMP)
	$(PY) -m gmcpt eval --quick

eval-full: $(STAMP)
	$(PY) -m gmcpt eval

clean:
	rm -rf $(OUT) .pytest_cache
