"""``blender -b -c radiosity ARGS`` without a Blender binary: the bpy module with this checkout
enabled as an extension runs the same command function (``radiosity_addon.cli.main``).

    .venv/bin/python tools/radiosity_command.py --input FILE.blend --output BAKED.blend [options]
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # a script, not the extension: finds tools/

from tools.source_extension import blender_with_extension  # noqa: E402

if __name__ == "__main__":
    _, package = blender_with_extension()
    sys.exit(package.radiosity_addon.cli.main(sys.argv[1:]))
