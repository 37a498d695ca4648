"""Build step beyond pyproject.toml: the firmware travels inside the package.

``mckibben export fmu --controller smc|pid`` compiles the core that runs on the Mega
(``firmware/core``) into the FMU; ``mckibben firmware build|flash|sketch`` and ``rig emulate
--engine avr`` build the whole firmware (``firmware/``: Makefile, src, core, the
processor-in-the-loop harness pil/, the sketch's .ino). It has one source, ``firmware/``; a built
package (wheel, ``pip install .``) carries copies as ``mckibben/export/firmware_core`` and
``mckibben/firmware``, made here, so an installed mckibben needs no source checkout.
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
#: The core's files an FMU compiles (mckibben.export.fmu.FIRMWARE_SOURCES and what they include).
CORE_FILES = ("*.c", "*.h")
#: The firmware's files an installed package builds from (mckibben.rig.firmware), by folder.
FIRMWARE_FILES = {".": ("Makefile",), "src": ("*.c", "*.h"), "core": ("*.c", "*.h"), "pil": ("*.c", "*.h"),
                  "sketch": ("*.ino",), "bench": ("*.c",)}


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
        for folder, patterns in FIRMWARE_FILES.items():
            out = Path(self.build_lib) / "mckibben" / "firmware" / folder
            out.mkdir(parents=True, exist_ok=True)
            for pattern in patterns:
                for f in (HERE / "firmware" / folder).glob(pattern):
                    shutil.copy2(f, out / f.name)


setup(cmdclass={"build_py": BuildPyWithFirmwareCore})
