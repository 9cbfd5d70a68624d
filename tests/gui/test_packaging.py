"""The desktop bundle's pieces: icon, .desktop entry and PyInstaller spec hang together."""

from __future__ import annotations

import ast
import configparser
from pathlib import Path

from PyQt5 import QtGui, QtSvg

from mimucap.resources import resource_path

REPO = Path(__file__).resolve().parents[2]


def test_icon_svg_and_png_render(qapp):
    renderer = QtSvg.QSvgRenderer(str(resource_path("icons/mimucap.svg")))
    assert renderer.isValid()
    png = QtGui.QImage(str(resource_path("icons/mimucap.png")))
    assert png.width() == png.height() >= 128
    assert png.pixelColor(png.width() // 2, png.height() // 2).alpha() == 255


def test_desktop_entry_names_the_command_and_icon():
    entry = configparser.ConfigParser(interpolation=None)
    entry.optionxform = str
    entry.read(REPO / "packaging" / "mimucap.desktop", encoding="utf-8")
    section = entry["Desktop Entry"]
    assert section["Type"] == "Application"
    assert section["Exec"].split()[0] == "mimucap"
    assert resource_path(f"icons/{section['Icon']}.svg").is_file()
    assert section["Categories"].endswith(";")


def test_pyinstaller_spec_points_at_existing_files():
    source = (REPO / "packaging" / "mimucap.spec").read_text(encoding="utf-8")
    ast.parse(source)
    for relative in ("app/mimucap/__main__.py", "resources/icons/mimucap.png", "resources/icons/mimucap.svg"):
        assert (REPO / relative).is_file(), relative
    assert '"mimucap/_resources"' in source
