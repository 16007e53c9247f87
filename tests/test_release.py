"""The release's words agree with the code: one version, printed by ``xarm-emu --version``, with its
section in CHANGELOG.md; docs/versioning.md names every firmware profile the CLI accepts and the
SDK version the tests pin; the metadata's Python classifiers are the versions the docs say are tested."""

from __future__ import annotations

import re
import subprocess
import sys
import tarfile
import tomllib
from pathlib import Path

from packaging.version import Version

from xarm_emu import __version__
from xarm_emu.protocol.firmware import SUPPORTED_VERSIONS

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
POLICY = (ROOT / "docs" / "versioning.md").read_text(encoding="utf-8")


def test_the_version_option_prints_one_line_and_exits_0() -> None:
    done = subprocess.run([sys.executable, "-m", "xarm_emu.cli", "--version"], capture_output=True,
                          text=True, timeout=60)
    assert (done.returncode, done.stdout, done.stderr) == (0, f"{__version__}\n", "")


def test_the_version_is_a_release_number_read_from_one_file() -> None:
    v = Version(__version__)
    assert str(v) == __version__ and not (v.is_prerelease or v.is_devrelease or v.local)
    assert "version" in PYPROJECT["project"]["dynamic"] and "version" not in PYPROJECT["project"]
    attr = PYPROJECT["tool"]["setuptools"]["dynamic"]["version"]["attr"]
    module, name = attr.rsplit(".", 1)
    path = ROOT / "src" / Path(*module.split(".")).with_suffix(".py")
    assert re.search(rf'^{name} = "{re.escape(__version__)}"$', path.read_text(), re.M)


def test_the_changelog_holds_this_release_under_unreleased() -> None:
    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    headings = re.findall(r"^## \[([^\]]+)\](.*)$", text, re.M)
    assert headings[0] == ("Unreleased", "")
    assert headings[1][0] == __version__
    assert re.fullmatch(r" - \d{4}-\d{2}-\d{2}", headings[1][1])
    assert len({h for h, _ in headings}) == len(headings)  # each release once


def test_the_policy_names_every_firmware_profile_and_the_pinned_sdk() -> None:
    named = re.findall(r"\b\d+\.\d+\.\d+\b", POLICY.split("## What a release is tested against")[1])
    assert [v for v in named if v in SUPPORTED_VERSIONS] == list(SUPPORTED_VERSIONS)
    (sdk,) = [d for d in PYPROJECT["project"]["optional-dependencies"]["test"]
              if d.startswith("xarm-python-sdk==")]
    assert f"`xarm-python-sdk` {sdk.split('==')[1]}" in POLICY


def test_the_classifiers_are_the_tested_pythons() -> None:
    prefix = "Programming Language :: Python :: "
    pythons = [c.removeprefix(prefix) for c in PYPROJECT["project"]["classifiers"]
               if c.startswith(prefix + "3.")]
    assert pythons == ["3.11", "3.12", "3.13"]
    assert PYPROJECT["project"]["requires-python"] == f">={pythons[0]}"
    assert "Python " + ", ".join(pythons[:-1]) + f" and {pythons[-1]}" in POLICY


def wheel_check(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(ROOT / "scripts" / "wheel-check"), *args], capture_output=True,
                          text=True, timeout=60)


def test_the_wheel_check_refuses_a_dist_without_one_wheel_in_one_line(tmp_path: Path) -> None:
    done = wheel_check(str(tmp_path))
    assert done.returncode == 1
    last = done.stderr.splitlines()[-1]
    assert last == (f"wheel-check: FAIL dist: {tmp_path} "
                    "holds 0 files xarm_emu-*.whl, not one (run `make dist`)")
    assert wheel_check(str(tmp_path), "--extra", "nothing").returncode == 2  # a usage mistake


def test_the_wheel_check_refuses_an_sdist_missing_the_checkout_s_files(tmp_path: Path) -> None:
    (tmp_path / f"xarm_emu-{__version__}-py3-none-any.whl").write_bytes(b"")
    with tarfile.open(tmp_path / f"xarm_emu-{__version__}.tar.gz", "w:gz") as tar:
        tar.add(ROOT / "pyproject.toml", arcname=f"xarm_emu-{__version__}/pyproject.toml")
    done = wheel_check(str(tmp_path))
    assert done.returncode == 1
    last = done.stderr.splitlines()[-1]
    assert last.startswith(f"wheel-check: FAIL dist: xarm_emu-{__version__}.tar.gz lacks ")
    assert "CHANGELOG.md" in last and "pyproject.toml" not in last
