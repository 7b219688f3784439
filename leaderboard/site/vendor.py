"""The browser libraries the results site ships: three.js and its glTF loader.

They are installed from npm into ``leaderboard/site/web/node_modules`` (``npm ci``
in that folder, pinned by its ``package-lock.json``) and copied into every site, so
the site works offline with no CDN.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from blendvoca.errors import UserError

__all__ = ["VENDOR_FILES", "WEB_DIR", "copy_vendor_files"]

#: Folder holding ``package.json`` / ``package-lock.json`` of the site's libraries.
WEB_DIR = Path(__file__).resolve().parent / "web"

#: ``node_modules`` path -> path inside the site's ``vendor/`` folder. The loader
#: imports ``three`` (mapped by the pages' import map) and ``../utils/BufferGeometryUtils.js``.
VENDOR_FILES = {
    "three/build/three.module.js": "three.module.js",
    "three/examples/jsm/loaders/GLTFLoader.js": "jsm/loaders/GLTFLoader.js",
    "three/examples/jsm/utils/BufferGeometryUtils.js": "jsm/utils/BufferGeometryUtils.js",
    "three/LICENSE": "three.LICENSE",
}


def copy_vendor_files(site_dir, node_modules=None) -> list[Path]:
    """Copy the pinned three.js files into ``<site_dir>/vendor``.

    Parameters
    ----------
    site_dir : path-like
    node_modules : path-like, optional
        Where npm installed them (default ``leaderboard/site/web/node_modules``).

    Returns
    -------
    list of Path
        The copied files.

    Raises
    ------
    UserError
        The npm packages are not installed; the message gives the command.
    """
    node_modules = Path(node_modules) if node_modules is not None else WEB_DIR / "node_modules"
    missing = [rel for rel in VENDOR_FILES if not (node_modules / rel).is_file()]
    if missing:
        raise UserError(
            f"leaderboard.site: three.js is not installed ({node_modules / missing[0]} missing); run "
            f"`npm ci --prefix {WEB_DIR}` once (it installs the version pinned in {WEB_DIR / 'package-lock.json'})"
        )
    copied = []
    for rel, dest in VENDOR_FILES.items():
        target = Path(site_dir) / "vendor" / dest
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(node_modules / rel, target)
        copied.append(target)
    return copied
