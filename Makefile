# Everything a newcomer runs. Each target sets up what it needs: two virtualenvs with the pinned
# packages of pyproject.toml, one per end of the supported Blender range (see its comments).
#   .venv        numpy, embreex, pytest, bpy 5.0.1   (bake, core tests, add-on tests, extension build)
#   .venv-bpy42  numpy, embreex, pytest, bpy 4.2.0   (add-on tests on the oldest supported Blender)
PYTHON ?= python3.11
VENV := .venv
VENV42 := .venv-bpy42
PY := $(VENV)/bin/python
PY42 := $(VENV42)/bin/python
SAMPLE := sample_blends/cornell_box.blend

.PHONY: bake test test-core test-addon extension bench clean

# A virtualenv is ready when its stamp is newer than pyproject.toml; re-running pip on a changed
# pyproject.toml moves the pins in place (bpy is about 400 MB: not downloaded again when it is already
# installed at the pinned version).
$(VENV)/.ready: GROUP := bpy50
$(VENV42)/.ready: GROUP := bpy42
$(VENV)/.ready $(VENV42)/.ready: pyproject.toml
	$(PYTHON) -m venv $(@D)
	$(@D)/bin/python -m pip install --quiet --upgrade pip
	$(@D)/bin/python -c "import tomllib; p = tomllib.load(open('pyproject.toml', 'rb'))['project']; \
	print('\n'.join(p['dependencies'] + p['optional-dependencies']['dev'] + p['optional-dependencies']['$(GROUP)']))" \
	> $(@D)/requirements.txt
	$(@D)/bin/python -m pip install --quiet -r $(@D)/requirements.txt
	touch $@

## Bake the sample Cornell box headless through the add-on, as `blender -b FILE -c radiosity` does:
## writes build/cornell_box_baked.blend and a picture of its colours, build/cornell_box_baked.png
bake: $(VENV)/.ready
	$(PY) tools/radiosity_command.py --input $(SAMPLE) --output build/cornell_box_baked.blend \
		--render build/cornell_box_baked.png

# Each run goes ahead even when an earlier one failed; $(REPORT) fails the target if any did.
CORE_TESTS = echo "== core tests"; $(PY) -m pytest tests/core tests/bench tests/farm -q || failed="$$failed core";
ADDON_TESTS = echo "== add-on tests, bpy 5.0.1"; $(PY) -m pytest tests/addon -q || failed="$$failed addon-bpy5.0.1"; \
	echo "== add-on tests, bpy 4.2.0"; $(PY42) -m pytest tests/addon -q || failed="$$failed addon-bpy4.2.0";
REPORT = if [ -n "$$failed" ]; then echo "FAILED:$$failed"; exit 1; fi

## The whole test suite: the core tests, the benchmarks' and the farm job type's (no Blender), then the add-on tests with bpy 5.0.1 and with
## bpy 4.2.0, each in a pytest process of its own (bpy can be imported once per process)
test: $(VENV)/.ready $(VENV42)/.ready
	@failed=""; $(CORE_TESTS) $(ADDON_TESTS) $(REPORT)

test-core: $(VENV)/.ready
	@failed=""; $(CORE_TESTS) $(REPORT)

test-addon: $(VENV)/.ready $(VENV42)/.ready
	@failed=""; $(ADDON_TESTS) $(REPORT)

## The installable extension: build/radiosity-<version>-<platform>.zip, one per platform with its
## embreex wheels (downloaded once into wheels/), built and validated by Blender's own extension
## tool. The committed blender_manifest.toml lists no wheels; tools/build_extension.py says why.
extension: $(VENV)/.ready
	$(PY) tools/build_extension.py --output-dir build

## Every study of bench/ (`$(PY) -m bench --help` lists them; each has a --quick check of a few minutes,
## written into build/bench-quick/): speed, accuracy and memory, the trade-off sweep of every knob, method,
## solver and preset, then ours against Cycles on the sample Cornell box, on the box with 40 x 40 walls and
## on Sponza, and Sponza's bakes against path tracing. Writes docs/results/ (the reports, their figures and
## the README's pictures) and keeps the raw results in build/bench/: about 75 minutes on 2 cores
bench: $(VENV)/.ready
	$(PY) -m bench benchmarks
	$(PY) -m bench tradeoffs
	$(PY) -m bench versus_cycles
	$(PY) -m bench fine_mesh
	$(PY) -m bench sponza
	$(PY) -m bench path_traced
	$(PY) -m bench resolve
	$(PY) -m bench breakfast
	$(PY) -m bench growth

# wheels/ stays: it only holds downloads, which the extension build and its test reuse
clean:
	rm -rf $(VENV) $(VENV42) build
