"""Only here to ship the Wireshark plugin (lua/*.lua, kept at the top of the repo) inside the
package as pndiss/lua/, so `pndiss wireshark install` works from a plain (non-editable) install."""
import glob
import os
import shutil

from setuptools import setup
from setuptools.command.build_py import build_py


class BuildWithLua(build_py):
    def run(self):
        super().run()
        dest = os.path.join(self.build_lib, "pndiss", "lua")
        os.makedirs(dest, exist_ok=True)
        for f in glob.glob(os.path.join(os.path.dirname(os.path.abspath(__file__)), "lua", "*.lua")):
            shutil.copy(f, dest)


setup(cmdclass={"build_py": BuildWithLua})
