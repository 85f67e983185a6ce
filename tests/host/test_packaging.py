"""The host package as a user installs it (issue 14.10).

`host/` alone builds an sdist that carries the firmware's C sources; a wheel
built from that sdist, far from the repository, installs and runs (the core
on its scalar kernel too); its extension needs nothing beyond baseline
x86-64 outside the kernels chosen at run time; the build prints no setuptools
warning; `aacmm sim` without a simulator says how to get one, and
`aacmm sim --board` never looks under the current directory.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest
from portability import vector_instruction_functions

pytestmark = pytest.mark.timeout(600)
HOST = Path(__file__).resolve().parents[2] / "host"


def _run(args: list[str], cwd: Path, env: dict[str, str] | None = None) -> str:
    out = subprocess.run(
        args,
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=500,
        env=env,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    return out.stdout + out.stderr


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """(directory the wheel is installed into, the build's output)."""
    tmp = tmp_path_factory.mktemp("pkg")
    # the sdist, from host/ alone (its egg-info scratch goes to tmp)
    log = _run(
        [sys.executable, "setup.py", "-q", "egg_info", "-e", str(tmp), "sdist", "-d", str(tmp)],
        HOST,
    )
    (sdist,) = tmp.glob("aacmm-*.tar.gz")
    with tarfile.open(sdist) as tar:
        names = tar.getnames()
        tar.extractall(tmp / "src")  # our own sdist, just built
    top = names[0].split("/")[0]
    for wanted in (
        "csrc/firmware/include/aacmm/simd.h",
        "csrc/firmware/src/kinematics_impl.h",
        "csrc/firmware/src/chain_impl.h",
        "csrc/firmware/src/simd/simd_impl.h",
        "csrc/firmware/src/encoder.c",
    ):
        assert f"{top}/{wanted}" in names, wanted
    # the wheel, built from the unpacked sdist: no repository around it
    src = tmp / "src" / top
    assert not (src.parent / "firmware").exists()
    log += _run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-w",
            str(tmp / "wheel"),
            str(src),
        ],
        tmp,
    )
    (wheel,) = (tmp / "wheel").glob("aacmm-*.whl")
    _run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--no-deps",
            "--target",
            str(tmp / "inst"),
            str(wheel),
        ],
        tmp,
    )
    return tmp / "inst", log


def _env(inst: Path, **extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("AACMM_SIM", "AACMM_ROOT")}
    env.update(PYTHONPATH=str(inst), PATH="/usr/bin:/bin", PYTHONWARNINGS="ignore", **extra)
    return env


def _aacmm(args: list[str], cwd: Path, inst: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "aacmm.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=60,
        env=_env(inst),
    )


def test_the_build_prints_no_setuptools_warning(installed: tuple[Path, str]) -> None:
    _, log = installed
    lowered = log.lower()
    assert "deprecat" not in lowered and "warning" not in lowered, log


def test_the_wheel_runs_far_from_the_repository(
    installed: tuple[Path, str], tmp_path: Path
) -> None:
    inst, _ = installed
    code = (
        "import aacmm, aacmm.core as c; print(aacmm.__file__); print(c.kernel()); "
        "print(c.Model().point([0.0] * 6)[2])"
    )
    for kernel in ("scalar", "auto"):
        out = _run([sys.executable, "-c", code], tmp_path, _env(inst, AACMM_KERNEL=kernel))
        where, name, z = out.split()[:3]
        assert where.startswith(str(inst)) and float(z) == pytest.approx(207.0)
        assert name == "scalar" or kernel == "auto"
    _run(
        [
            sys.executable,
            "-m",
            "aacmm.cli",
            "mc",
            "-n",
            "5000",
            "--seed",
            "1",
            "-q",
            "--json",
            "m.json",
        ],
        tmp_path,
        _env(inst, AACMM_KERNEL="scalar"),
    )
    assert json.loads((tmp_path / "m.json").read_text())["n"] == 5000
    (so,) = (inst / "aacmm").glob("_core*.so")
    if platform.machine() == "x86_64":
        wide, other = vector_instruction_functions(str(so))
        assert wide and other == [], other


def test_the_wheel_carries_every_data_file(installed: tuple[Path, str], tmp_path: Path) -> None:
    """The shipped data (plans, models, DBCs, examples, the paper's table) are in
    the wheel, and the shipped plans and models load from the installed package."""
    inst, _ = installed
    src = HOST / "src" / "aacmm" / "data"
    shipped = {p.relative_to(src) for p in src.rglob("*") if p.is_file()}
    got = {p.relative_to(inst / "aacmm" / "data") for p in (inst / "aacmm" / "data").rglob("*")}
    assert shipped <= got, sorted(map(str, shipped - got))
    code = (
        "from aacmm.plans import load_plan; from aacmm.analysis import uncertainty as u; "
        "from aacmm.models import load_model, shipped_models; "
        "print(len(load_plan('iso10360-12').slots), u.load_spec('example').u_vector().size, "
        "' '.join(shipped_models()), load_model('commercial7').n_params)"
    )
    out = _run([sys.executable, "-c", code], tmp_path, _env(inst))
    from aacmm.models import load_model, shipped_models  # the source tree's
    from aacmm.plans import load_plan

    assert out.split()[:2] == [str(len(load_plan("iso10360-12").slots)), "25"], out
    assert out.split()[2:] == [*shipped_models(), str(load_model("commercial7").n_params)], out


def test_sim_without_a_simulator_says_how_to_get_one(
    installed: tuple[Path, str], tmp_path: Path
) -> None:
    inst, _ = installed
    out = _aacmm(["sim"], tmp_path, inst)
    assert out.returncode == 3
    (line,) = out.stderr.strip().splitlines()
    assert "not part of the pip package" in line and "make sim" in line and "AACMM_SIM" in line


def test_sim_board_never_looks_under_the_current_directory(
    installed: tuple[Path, str], tmp_path: Path
) -> None:
    inst, _ = installed
    planted = tmp_path / "build" / "boards" / "microbit" / "fw.elf"
    planted.parent.mkdir(parents=True)
    planted.write_bytes(b"not an image")
    out = _aacmm(["sim", "--board", "microbit"], tmp_path, inst)
    assert out.returncode == 3
    (line,) = out.stderr.strip().splitlines()
    assert "source tree" in line and "AACMM_ROOT" in line and str(tmp_path) not in line
