"""Help → User Guide opens the clinician's guide shipped in the package, readable offline."""

from __future__ import annotations

import re

from PyQt5 import QtCore, QtGui

from mimucap.gui.user_guide import GUIDE, guide_path
from mimucap.resources import resources_root


def test_the_guide_opens_from_the_help_menu_and_covers_a_session(window, qtbot):
    assert guide_path() == resources_root() / GUIDE  # shipped with the resources (mimucap/_resources)
    window.action_guide.trigger()
    guide = window._guide
    qtbot.waitExposed(guide)
    text = guide.text()
    for section in ("Set-up", "Magnetometer calibration", "N-pose and T-pose", "Recording", "Review", "Export",
                    "As seen live, or reprocessed", "Using the files in other programs", "OpenSim", "Visual3D",
                    "Blender", "Gait parameters", "Range of motion", "The report", "The library and comparisons",
                    "Clinical tests", "What each verdict and warning means"):
        assert section in text, section
    for verdict in ("Good", "Usable, with a warning", "Failed — redo", "Acceptable", "Poor", "Refused",
                    "STALE: no data", "STALE: packets arrive but are refused"):
        assert verdict in text, verdict
    # every link inside the guide leads to a section of it; no link needs the network
    html = guide_path().read_text(encoding="utf-8")
    anchors = set(re.findall(r'id="([^"]+)"', html))
    links = re.findall(r'href="([^"]+)"', html)
    assert links and all(link.startswith("#") and link[1:] in anchors for link in links)
    assert "http" not in html
    # every picture is a file shipped beside the guide, and the guide window shows it
    images = re.findall(r'<img [^>]*src="([^"]+)"', html)
    assert len(images) >= 9
    for src in images:
        assert src.startswith("img/") and (guide_path().parent / src).is_file(), src
        image = guide.browser.document().resource(QtGui.QTextDocument.ImageResource, QtCore.QUrl(src))
        if isinstance(image, QtCore.QByteArray):
            image = QtGui.QImage.fromData(image)
        assert isinstance(image, (QtGui.QImage, QtGui.QPixmap)) and not image.isNull(), src
    shipped = sum(path.stat().st_size for path in (guide_path().parent / "img").iterdir())
    assert shipped < 2.5e6  # the pictures travel in every wheel and bundle
    window.action_guide.trigger()  # a second time: the same window comes back
    assert window._guide is guide and guide.isVisible()
    guide.close()
