"""The installed products' tests run in their own make targets, against what those built:
``make bundle-check`` names the bundle (``MIMUCAP_BUNDLE``), ``make wheel-check`` the wheel's
environment (``MIMUCAP_WHEEL_PYTHON``). Without them the files are not collected at all, so the
suite's count of skipped tests holds only tests whose external data is missing."""

import os

collect_ignore = [name for name, env in (("test_bundle_smoke.py", "MIMUCAP_BUNDLE"),
                                         ("test_wheel.py", "MIMUCAP_WHEEL_PYTHON")) if not os.environ.get(env)]
