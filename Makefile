# Everything a newcomer runs. Each target sets up what it needs (.venv with pinned packages).
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
SAMPLE := sample_blends/cornell_box.obj

.PHONY: bake test test-core bench clean

$(VENV)/.ready: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -c "import tomllib; p = tomllib.load(open('pyproject.toml', 'rb'))['project']; \
	print('\n'.join(p['dependencies'] + p['optional-dependencies']['dev']))" > $(VENV)/requirements.txt
	$(PY) -m pip install --quiet -r $(VENV)/requirements.txt
	touch $@

## Bake the bundled Cornell box headless; prints what it did and writes build/cornell_box_baked.ply
bake: $(VENV)/.ready
	$(PY) -m core bake $(SAMPLE) --subdivide 4 --output build/cornell_box_baked.ply

## The whole test suite (core tests need no Blender; add-on tests will run in a pytest process of their own)
test: $(VENV)/.ready
	$(PY) -m pytest tests/core -q

## Speed and accuracy figures (see docs/benchmarks.md)
bench: $(VENV)/.ready
	$(PY) bench/run.py

clean:
	rm -rf $(VENV) build
