"""The studies, one module each, run by ``python -m bench <study>`` (bench/__main__.py lists them);
a module named ``<study>_<part>`` is a part of that study."""
