"""exhibit.geometry is pure math: numpy and the standard library only, no GL, devices or I/O."""

import ast
import pathlib
import subprocess
import sys

import exhibit.geometry

ALLOWED = {"__future__", "math", "dataclasses", "typing", "collections", "numpy"}
PACKAGE = pathlib.Path(exhibit.geometry.__file__).parent


def test_geometry_imports_only_numpy_and_pure_stdlib():
    for path in sorted(PACKAGE.glob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                assert top in ALLOWED or name.startswith("exhibit.geometry"), (
                    f"{path.name} imports {name}"
                )


def test_importing_geometry_loads_no_gl_or_device_modules():
    code = (
        "import sys, exhibit.geometry; "
        "print(sorted(m for m in ('moderngl', 'glfw', 'hid', 'hidraw', 'serial', 'PIL') "
        "if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
