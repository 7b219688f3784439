import os
import shutil
from pathlib import Path

import pytest

from blendvoca import assets, cli
from blendvoca.assets import AssetError, load_manifest, resolve
from tests.fixtures.assets import REALDATA_MARK

#: The folders of shared/realdata (the real recordings data_manifest.yaml names, SOURCES.md there).
REALDATA_FOLDERS = ("facegood", "beat2", "vocaset_audio")


def _realdata_here() -> Path | None:
    """The real-data folder ``$BLENDVOCA_ASSETS`` names, if any."""
    for part in os.environ.get("BLENDVOCA_ASSETS", "").split(os.pathsep):
        if part and (Path(part) / REALDATA_MARK).is_file():
            return Path(part)
    return None


def _ids_here() -> list[str]:
    """Every asset id, less the real recordings when no folder of them is named."""
    realdata = _realdata_here()
    return [i for i, e in load_manifest().items()
            if realdata is not None or (e.get("mirror") or "").split("/")[0] not in REALDATA_FOLDERS]


def test_manifest_names_every_real_recording_with_its_sha256(realdata_dir):
    """Every file of shared/realdata (less SOURCES.md) has an entry: mirror = its path there, the
    same size and sha256, a raw URL at a commit, a licence."""
    entries = {e["mirror"]: e for e in load_manifest().values() if e.get("mirror")}
    files = sorted(p for p in realdata_dir.rglob("*") if p.is_file() and p.name != "SOURCES.md")
    assert len(files) == 18
    for path in files:
        rel = path.relative_to(realdata_dir).as_posix()
        item = entries[rel]
        assert item["sha256"] == assets.sha256_of(path) and item["size"] == path.stat().st_size, rel
        assert item["url"].startswith("https://raw.githubusercontent.com/") and item["licence"], rel
        commit = item["url"].split("/")[5]
        assert len(commit) == 40 and all(c in "0123456789abcdef" for c in commit), item["url"]
        assert item["url"].endswith(path.name) or rel == "facegood/bs_names_1015.npy"


def test_several_asset_folders_are_searched_in_order(tmp_path, monkeypatch):
    first, second = tmp_path / "a", tmp_path / "b"
    for folder in (first, second):
        (folder / "said").mkdir(parents=True)
    (second / "said" / "ARKit_blendshapes.txt").write_text("x")
    monkeypatch.setenv("BLENDVOCA_ASSETS", os.pathsep.join([str(first), "", str(second)]))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))
    assert assets.asset_dirs() == [first, second]
    assert assets.search_dirs() == [first, second, tmp_path / "cache" / "assets"]
    assert assets.find_local("arkit-blendshape-names") == second / "said" / "ARKit_blendshapes.txt"
    (first / "said" / "ARKit_blendshapes.txt").write_text("y")
    assert assets.find_local("arkit-blendshape-names") == first / "said" / "ARKit_blendshapes.txt"


def test_manifest_covers_every_mirrored_file(assets_dir):
    mirrors = {e.get("mirror") for e in load_manifest().values()}
    files = {str(p.relative_to(assets_dir)) for p in assets_dir.rglob("*") if p.is_file() and p.name != "SOURCES.md"}
    assert files <= mirrors
    for item in load_manifest().values():
        assert {"id", "url", "licence", "access", "used_by"} <= set(item)
        if item["access"] == "public":
            assert len(item["sha256"]) == 64 and item["size"] > 0 and "/" in item["mirror"]
            # Pinned to a commit, never a branch.
            assert "/main/" not in item["url"] and "/master/" not in item["url"]


def test_resolve_finds_and_verifies(assets_dir):
    path = resolve("said-vae")
    assert path.resolve() == (assets_dir / "said" / "vae.pth").resolve()
    assert len(assets.load_index_list("flame-head-idx")) == 4580


def test_registration_asset_explains_what_to_do():
    with pytest.raises(AssetError, match=r"registration.*voca\.is\.tue\.mpg\.de|voca\.is\.tue\.mpg\.de"):
        resolve("vocaset")


def test_unknown_id_lists_close_matches():
    with pytest.raises(KeyError, match="said-vae"):
        resolve("said-vea")


@pytest.fixture()
def corrupted_mirror(tmp_path, assets_dir, monkeypatch):
    mirror = tmp_path / "assets"
    shutil.copytree(assets_dir, mirror)
    path = mirror / "said" / "coeffs_std.csv"
    path.chmod(0o644)
    path.write_text(path.read_text().replace("0.1243", "0.1244"))
    realdata = _realdata_here()
    monkeypatch.setenv("BLENDVOCA_ASSETS", os.pathsep.join([str(mirror)] + ([str(realdata)] if realdata else [])))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))
    return mirror


def test_corrupted_copy_is_rejected(corrupted_mirror):
    with pytest.raises(AssetError, match=r"coeffs_std\.csv has sha256 .* expected 6314c5b7"):
        resolve("coeffs-std")


def test_verify_cli_exits_nonzero_on_mismatch(corrupted_mirror, capsys):
    # A corrupted copy is a check that found a problem (exit 4); exit 1 means an internal bug.
    assert assets.main(["verify", *_ids_here()]) == cli.EXIT_CHECK_FAILED
    captured = capsys.readouterr()
    assert "corrupted coeffs-std" in captured.out and "ok       said-vae" in captured.out
    err = [line for line in captured.err.splitlines() if line.strip()]
    assert len(err) == 1 and err[0].startswith("error: 1 asset(s) failed verification"), captured.err
    assert "Traceback" not in captured.err


def test_verify_cli_exit_status_for_a_missing_public_asset(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(tmp_path / "empty"))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))
    assert assets.main(["verify", "said-vae"]) == cli.EXIT_CHECK_FAILED
    assert "missing  said-vae" in capsys.readouterr().out


def test_unknown_asset_id_is_one_error_line(capsys):
    assert assets.main(["verify", "said-vea"]) == cli.EXIT_USER
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: unknown asset id 'said-vea'") and "said-vae" in err[0]


def test_fetch_that_cannot_reach_an_asset_lists_it_and_exits_partial(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(tmp_path / "empty"))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))
    assert assets.main(["fetch", "vocaset"]) == cli.EXIT_PARTIAL
    assert "error    asset 'vocaset'" in capsys.readouterr().out


def test_verify_cli_passes_on_the_mirror(assets_dir, capsys):
    assert assets.main(["verify", *_ids_here()]) == 0


def test_unreachable_download_says_where_to_put_the_file(tmp_path, monkeypatch):
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(tmp_path / "empty"))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))

    def offline(*args, **kwargs):
        import urllib.error

        raise urllib.error.URLError("network is unreachable")

    monkeypatch.setattr(assets.urllib.request, "urlopen", offline)
    with pytest.raises(AssetError, match=r"could not download.*raw\.githubusercontent.*Put the file at .*said/vae\.pth"):
        resolve("said-vae")
    assert not list((tmp_path / "cache").rglob("*.part"))


def test_fetch_of_everything_lists_manual_assets_and_exits_0(assets_dir, capsys):
    # every downloadable asset is in the mirror; the registration-only and manual ones are listed, not failures
    if _realdata_here() is None:
        pytest.skip("a plain fetch needs the real recordings too: name shared/realdata in BLENDVOCA_ASSETS")
    assert assets.main(["fetch"]) == cli.EXIT_OK
    out = capsys.readouterr().out
    manual = [asset_id for asset_id, item in load_manifest().items() if item["access"] != "public"]
    assert manual and all(f"manual   {asset_id}: " in out for asset_id in manual)
    assert "voca.is.tue.mpg.de" in out and "error" not in out
    assert f"{len(manual)} manual asset(s) not present" in out


def test_fetch_of_everything_still_fails_for_a_missing_public_asset(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(tmp_path / "empty"))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))

    def offline(*args, **kwargs):
        import urllib.error

        raise urllib.error.URLError("network is unreachable")

    monkeypatch.setattr(assets.urllib.request, "urlopen", offline)
    assert assets.main(["fetch"]) == cli.EXIT_PARTIAL
    out = capsys.readouterr().out
    assert "error    could not download asset 'said-vae'" in out and "manual   vocaset: " in out


def test_path_prints_each_assets_local_path_for_a_shell(assets_dir, capsys):
    assert assets.main(["path", "speech-voca", "said-vae"]) == cli.EXIT_OK
    out = capsys.readouterr().out.splitlines()
    assert [Path(line) for line in out] == [resolve("speech-voca"), resolve("said-vae")]
    assert out[0].endswith("voca/test_sentence.wav")


def test_path_of_a_manual_asset_or_of_nothing_is_one_error_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(tmp_path / "empty"))
    assert assets.main(["path", "vocaset"]) == cli.EXIT_USER
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert captured.out == "" and len(err) == 1 and "voca.is.tue.mpg.de" in err[0]
    assert assets.main(["path"]) == cli.EXIT_USER
    assert "name the asset" in capsys.readouterr().err
