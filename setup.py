"""Build step beyond pyproject.toml: the firmware's C controller core travels inside the package.

``mckibben export fmu --controller smc|pid`` compiles the core that runs on the Mega
(``firmware/core``) into the FMU. It has one source, ``firmware/core``; a built package
(wheel, ``pip install .``) carries a copy as ``mckibben/export/firmware_core``, made here, so an
installed mckibben exports closed-loop FMUs without a source checkout.
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
#: The core's files an FMU compiles (mckibben.export.fmu.FIRMWARE_SOURCES and what they include).
CORE_FILES = ("*.c", "*.h")


class BuildPyWithFirmwareCore(build_py):
    def run(self):
        super().run()
        src = HERE / "firmware" / "core"
        if not src.is_dir():  # building from an sdist without it: the export says what is missing
            return
        dst = Path(self.build_lib) / "mckibben" / "export" / "firmware_core"
        dst.mkdir(parents=True, exist_ok=True)
        for pattern in CORE_FILES:
            for f in src.glob(pattern):
                shutil.copy2(f, dst / f.name)


setup(cmdclass={"build_py": BuildPyWithFirmwareCore})
