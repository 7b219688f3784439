import shutil

import pytest

from blendvoca import assets, cli
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
    # A corrupted copy is a check that found a problem (exit 4); exit 1 means an internal bug.
    assert assets.main(["verify"]) == cli.EXIT_CHECK_FAILED
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
