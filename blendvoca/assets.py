"""Resolve the external files named in ``data_manifest.yaml`` to local paths.

``python -m blendvoca.assets list|verify|fetch [ID ...]`` lists them, checks the local
copies against their sha256 (exit status 4 when one is corrupted or missing) and
downloads what is missing; ``python -m blendvoca.assets path ID ...`` prints the local
path of each (fetched first when missing), for a shell: ``--audio "$(python -m
blendvoca.assets path speech-voca)"``.

Lookup order for an asset with a ``mirror`` path:

1. ``$BLENDVOCA_ASSETS/<mirror>`` (a directory laid out like ``shared/assets``; several
   directories separated by ``os.pathsep``, ``:`` on POSIX, are searched in order, e.g.
   ``shared/assets:shared/realdata`` for the assets and the real recordings);
2. the user cache, ``$BLENDVOCA_CACHE`` or ``$XDG_CACHE_HOME/blendvoca`` or
   ``~/.cache/blendvoca``, under ``assets/<mirror>``;
3. a download from the pinned ``url`` into the cache, verified against ``sha256``.

A file found in 1 or 2 is checked against its sha256 too, so a corrupted copy is
reported rather than used. Assets that need registration (VOCASET) or a manual step
(SyncNet, wav2vec 2.0 weights) are never downloaded: `resolve` raises `AssetError`
with the instructions from the manifest.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import urllib.error
import urllib.request
from functools import lru_cache
from pathlib import Path

import numpy as np
import yaml

from blendvoca import cli
from blendvoca.errors import CheckFailed, DataError, UserError
from blendvoca.io.atomic import permissions_for
from blendvoca.io.mesh import read_index_list

MANIFEST_PATH = Path(__file__).with_name("data_manifest.yaml")


class AssetError(UserError, RuntimeError):
    """An asset is missing, corrupted, or cannot be downloaded here (a `UserError`)."""


class UnknownAssetError(UserError, KeyError):
    """An asset id that ``data_manifest.yaml`` does not name (a `UserError` and a ``KeyError``);
    the message lists the close matches and the known ids."""

    def __str__(self) -> str:  # KeyError would print the message in quotes
        return str(self.args[0]) if self.args else ""


@lru_cache(maxsize=None)
def load_manifest(path: Path = MANIFEST_PATH) -> dict[str, dict]:
    """Manifest entries keyed by asset id."""
    with open(path, encoding="utf-8") as f:
        document = yaml.safe_load(f)
    entries = {}
    for entry in document["assets"]:
        if entry["id"] in entries:
            raise DataError(f"{path}: asset id {entry['id']!r} appears twice")
        entries[entry["id"]] = entry
    return entries


def cache_dir() -> Path:
    """The user cache of BlendVOCA (assets, bundled-default corpora and builds)."""
    if os.environ.get("BLENDVOCA_CACHE"):
        return Path(os.environ["BLENDVOCA_CACHE"]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base).expanduser() / "blendvoca"


def asset_dirs() -> list[Path]:
    """The directories ``$BLENDVOCA_ASSETS`` names (several separated by ``os.pathsep``), in order."""
    return [Path(part).expanduser() for part in os.environ.get("BLENDVOCA_ASSETS", "").split(os.pathsep) if part]


def search_dirs() -> list[Path]:
    """Directories searched for mirrored assets, in order."""
    dirs = asset_dirs()
    dirs.append(cache_dir() / "assets")
    return dirs


def sha256_of(path: Path, chunk: int = 1 << 20) -> str:
    """Hex sha256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(chunk), b""):
            digest.update(block)
    return digest.hexdigest()


_verified: dict[tuple[str, int, int], str] = {}


def _checked_sha256(path: Path) -> str:
    # Hash each (path, size, mtime) once per process: resolve() is called often.
    stat = path.stat()
    key = (str(path.resolve()), stat.st_size, stat.st_mtime_ns)
    if key not in _verified:
        _verified[key] = sha256_of(path)
    return _verified[key]


def entry(asset_id: str) -> dict:
    """The manifest entry of ``asset_id``; unknown ids raise :class:`UnknownAssetError` listing the known ones."""
    manifest = load_manifest()
    if asset_id not in manifest:
        import difflib

        close = difflib.get_close_matches(asset_id, manifest, n=3)
        hint = f" Did you mean {close}?" if close else ""
        raise UnknownAssetError(f"unknown asset id {asset_id!r}.{hint} Known ids: {sorted(manifest)}")
    return manifest[asset_id]


def _where_to_put(item: dict) -> str:
    mirror = item.get("mirror")
    if not mirror:
        return ""
    places = " or ".join(str(d / mirror) for d in search_dirs())
    return (f" Put the file at {places} (set BLENDVOCA_ASSETS to a directory laid out like shared/assets, or "
            f"several separated by {os.pathsep!r}).")


def find_local(asset_id: str) -> Path | None:
    """Path of a local copy of ``asset_id`` (not verified), or None."""
    item = entry(asset_id)
    if not item.get("mirror"):
        return None
    for directory in search_dirs():
        candidate = directory / item["mirror"]
        if candidate.exists():
            return candidate
    return None


def verify_file(asset_id: str, path: Path) -> None:
    """Raise `AssetError` if ``path`` does not match the manifest's sha256."""
    item = entry(asset_id)
    expected = item.get("sha256")
    if expected is None or path.is_dir():
        return
    actual = _checked_sha256(path)
    if actual != expected:
        raise AssetError(
            f"asset {asset_id!r} at {path} has sha256 {actual}, expected {expected} "
            f"(data_manifest.yaml). The file is corrupted or a different version: delete it and "
            f"download it again from {item['url']}.{_where_to_put(item)}"
        )


def download(asset_id: str, destination: Path | None = None) -> Path:
    """Download ``asset_id`` from its pinned URL into the cache, verifying sha256."""
    item = entry(asset_id)
    if item.get("access") != "public":
        raise AssetError(_manual_message(asset_id, item))
    destination = destination or cache_dir() / "assets" / item["mirror"]
    destination.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile(dir=destination.parent, delete=False, suffix=".part") as tmp:
        try:
            with urllib.request.urlopen(item["url"], timeout=60) as response:
                shutil.copyfileobj(response, tmp)
        except (urllib.error.URLError, OSError) as error:
            tmp.close()
            os.unlink(tmp.name)
            raise AssetError(
                f"could not download asset {asset_id!r} from {item['url']}: {error}. "
                f"Download it on a machine with internet (sha256 {item['sha256']}).{_where_to_put(item)}"
            ) from error
    try:
        verify_file(asset_id, Path(tmp.name))
    except AssetError:
        os.unlink(tmp.name)
        raise
    os.chmod(tmp.name, permissions_for(destination))
    os.replace(tmp.name, destination)
    return destination


def _manual_message(asset_id: str, item: dict) -> str:
    how = item.get("instructions", f"Download it from {item['url']}.")
    return f"asset {asset_id!r} ({item.get('licence', 'see its licence')}) cannot be downloaded automatically. {how}{_where_to_put(item)}"


def resolve(asset_id: str, *, download_missing: bool = True) -> Path:
    """Local path of a verified copy of ``asset_id``.

    Raises
    ------
    AssetError
        Registration-only or manual assets that are not present, checksum
        mismatches, or a failed download; the message says what to fetch from where
        and where to put it.
    """
    item = entry(asset_id)
    local = find_local(asset_id)
    if local is not None:
        verify_file(asset_id, local)
        return local
    if item.get("access") != "public":
        raise AssetError(_manual_message(asset_id, item))
    if not download_missing:
        raise AssetError(f"asset {asset_id!r} is not present locally.{_where_to_put(item)}")
    return download(asset_id)


def load_index_list(asset_id: str) -> np.ndarray:
    """An index list asset (landmarks, crop) as ``(N,) int64``."""
    return read_index_list(resolve(asset_id))


def _status(asset_id: str) -> tuple[str, Path | None]:
    """(status word, local path) of one asset: ok, missing, corrupted or manual."""
    item = entry(asset_id)
    local = find_local(asset_id)
    if local is None:
        return ("manual" if item.get("access") != "public" else "missing"), None
    try:
        verify_file(asset_id, local)
    except AssetError:
        return "corrupted", local
    return "ok", local


@cli.command
def main(argv: list[str] | None = None) -> int:
    """``python -m blendvoca.assets list|verify|fetch [ID ...]``, ``python -m blendvoca.assets path ID ...``.

    Exit status: 0 done; 2 an unknown asset id; 4 (``verify``) some local copy is
    corrupted or a public asset is missing; 5 (``fetch``) some asset could not be
    fetched (each is listed, the others were). A plain ``fetch`` (no ids) lists the
    registration-only and manual assets that are not present as ``manual`` with their
    instructions and exits 0 when every downloadable one is present; naming such an id
    (``fetch vocaset``) asks for it, so it fails (5) with the instructions.
    """
    parser = cli.parser("blendvoca.assets", __doc__)
    parser.add_argument("command", choices=["list", "verify", "fetch", "path"])
    parser.add_argument("ids", nargs="*", help="asset ids (default: all; path: at least one)")
    args = parser.parse_args(argv)
    if args.command == "path" and not args.ids:
        raise UserError("path: name the asset(s), e.g. python -m blendvoca.assets path speech-voca")
    ids = args.ids or list(load_manifest())
    for asset_id in ids:
        entry(asset_id)  # unknown ids fail before any work
    if args.command == "path":  # one line per asset, nothing else on stdout; a missing manual one: exit 2
        paths = [resolve(asset_id) for asset_id in ids]
        print("\n".join(str(path) for path in paths))
        return cli.EXIT_OK
    failures = manual = 0
    for asset_id in ids:
        item = entry(asset_id)
        if args.command == "list":
            status, local = _status(asset_id)
            size = f"{item['size']:>9d} B" if "size" in item else " " * 11
            print(f"{asset_id:24s} {item['access']:12s} {size}  {status:9s} {local or item['url']}")
        elif args.command == "verify":
            if item.get("access") != "public" and find_local(asset_id) is None:
                print(f"skip     {asset_id}: {item['access']} asset, not present")
                continue
            status, local = _status(asset_id)
            print(f"{status:8s} {asset_id}: {local or 'not found in ' + ', '.join(map(str, search_dirs()))}")
            failures += status != "ok"
        else:
            if not args.ids and item.get("access") != "public" and find_local(asset_id) is None:
                # registration-only or manual: never downloaded, so not a failure of a plain fetch
                print(f"manual   {asset_id}: {item['access']} asset, not downloaded automatically; "
                      f"{item.get('instructions', 'see ' + item['url'])}{_where_to_put(item)}".rstrip())
                manual += 1
                continue
            try:
                print(f"ok       {asset_id}: {resolve(asset_id)}")
            except AssetError as error:
                # One asset that cannot be fetched here does not stop the others.
                print(f"error    {error}")
                failures += 1
    if manual:
        print(f"{manual} manual asset(s) not present (listed above with how to get each); every "
              "downloadable asset is fetched" if not failures else f"{manual} manual asset(s) not present (listed above)")
    if failures:
        print(f"{failures} asset(s) failed")
        if args.command == "verify":
            raise CheckFailed(f"{failures} asset(s) failed verification (listed above): delete each corrupted "
                              "copy and fetch it again (python -m blendvoca.assets fetch ID)")
        return cli.EXIT_PARTIAL
    return cli.EXIT_OK


if __name__ == "__main__":
    raise SystemExit(main())
