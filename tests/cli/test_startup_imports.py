"""``mimucap --help``, ``--version`` and ``mimucap COMMAND --help`` load no heavy library.

Each command module imports only argparse and the standard library at its top and loads
numpy, numba, h5py, Qt or VTK inside its run function, so that a command starts in a tenth of
a second instead of two (the numba kernels alone took a second to import). Checked in a fresh
interpreter, through ``sys.modules``: what the test process itself imported does not count.
"""

from __future__ import annotations

import json
import subprocess
import sys

from mimucap.cli import COMMAND_MODULES

HEAVY = ("numpy", "numba", "llvmlite", "scipy", "h5py", "PyQt5", "vtk", "vtkmodules", "pyqtgraph")

PROBE = r"""
import contextlib, importlib, io, json, sys
import mimucap.cli as cli
for module in json.loads(sys.argv[3]):  # what a careless command module would import at its top
    importlib.import_module(module)
parser = cli.build_parser()
seen = {}
for argv in json.loads(sys.argv[1]):
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            parser.parse_args(argv)
        except SystemExit:
            pass
    seen[" ".join(argv)] = sorted(name for name in json.loads(sys.argv[2]) if name in sys.modules)
print(json.dumps(seen))
"""


def loaded_after(argvs: list[list[str]], also_import: tuple[str, ...] = ()) -> dict[str, list[str]]:
    done = subprocess.run([sys.executable, "-c", PROBE, json.dumps(argvs), json.dumps(HEAVY),
                           json.dumps(also_import)],
                          capture_output=True, text=True, timeout=60, check=True)
    return json.loads(done.stdout)


def test_the_parser_and_every_help_import_no_heavy_library() -> None:
    argvs = [["--version"], ["--help"]] + [[name, "--help"] for name in COMMAND_MODULES]
    argvs += [["magcal", "fit", "--help"], ["magcal", "study", "--help"], ["emulate", "udp", "--help"],
              ["bench", "orientation", "--help"]]
    seen = loaded_after(argvs)
    assert seen == {" ".join(argv): [] for argv in argvs}


def test_the_probe_sees_a_heavy_import() -> None:
    """The check above can fail: a module importing the fusion kernels at its top is seen."""
    seen = loaded_after([["fuse", "--help"]], also_import=("mimucap.core.fusion.kernels",))
    assert {"numpy", "numba"} <= set(seen["fuse --help"])


def test_the_names_listed_in_help_are_those_the_modules_accept() -> None:
    from mimucap.core.simulate.names import ERROR_PRESET_NAMES
    from mimucap.core.simulate.sensor_errors import ERROR_PRESETS

    assert ERROR_PRESET_NAMES == tuple(ERROR_PRESETS)
