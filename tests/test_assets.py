import shutil

import pytest

from blendvoca import assets
from blendvoca.assets import AssetError, load_manifest, resolve


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
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(mirror))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))
    return mirror


def test_corrupted_copy_is_rejected(corrupted_mirror):
    with pytest.raises(AssetError, match=r"coeffs_std\.csv has sha256 .* expected 6314c5b7"):
        resolve("coeffs-std")


def test_verify_cli_exits_nonzero_on_mismatch(corrupted_mirror, capsys):
    assert assets.main(["verify"]) == 1
    out = capsys.readouterr().out
    assert "corrupted coeffs-std" in out and "ok       said-vae" in out


def test_verify_cli_passes_on_the_mirror(assets_dir, capsys):
    assert assets.main(["verify"]) == 0


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
