"""Arm models over the wire (issue 26): a 7-axis and a 5-axis arm on the pty simulator.

The arms are built here with :class:`aacmm.arm.Arm` (modified DH, Hayati betas
on parallel hinges, a tip vector), sent to the simulated device as parameter
sets (SET_PARAMS, or ``aacmm-sim --param-set``), and every point and Jacobian
the device computes (COMPUTE, MEASURE, the stream) is checked against
``aacmm.core`` evaluated on the host in double precision from the arm and the
counts: within the float path's bound (1 um; the Jacobian to float32's
accuracy). Also: a 7-joint set saved and reloaded across a restart, the
device refusing counts of another joint count, and the version errors between
protocol version 4 and the older versions 3 (before device temperatures), 2
(before the error model's layout) and 1 (six joints) in both directions.
"""

from __future__ import annotations

import math
import random
import struct
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from aacmm import core
from aacmm.arm import Arm, Joint
from aacmm.client import Client, connect
from aacmm.errors import DeviceError, FrameError
from aacmm.protocol import (
    PROTOCOL_VERSION,
    MsgType,
    ParamSet,
    SampleStatus,
    decode_message,
    encode_frame,
    encode_param_set,
)
from aacmm.protocol.framing import Deframer
from aacmm.protocol.status import Status
from fakedevice import SerialFakeServer
from simproc import SIM_BIN, Sim

FLOAT_PATH_BOUND_MM = 1e-3  # the device's single-precision chain against float64


def arm7() -> Arm:
    """Seven axes of commercial proportions: base swivel, shoulder, elbow (the two
    hinges parallel-ish: a beta on the elbow), three wrist axes and a handle roll;
    modified DH on the wrist, a tip vector with an offset probe."""
    h = math.pi / 2
    return Arm(
        (
            Joint(alpha_rad=h, d_mm=250.0),
            Joint(alpha_rad=0.002, a_mm=600.0, theta_offset_rad=0.01),
            Joint(alpha_rad=h, a_mm=40.0, d_mm=5.0, beta_rad=0.0015),
            Joint(alpha_rad=-h, d_mm=550.0),
            Joint(convention="modified", alpha_rad=h, a_mm=30.0, d_mm=2.0),
            Joint(convention="modified", alpha_rad=-h, d_mm=120.0),
            Joint(convention="modified", alpha_rad=h, a_mm=3.0, d_mm=60.0),
        ),
        "xyz",
        (1.5, -2.0, 110.0),
    )


def arm5() -> Arm:
    """Five axes with two parallel hinges (joints 2 and 3, 4 with a beta each),
    modified DH throughout (the MicroScribe's convention), tip l."""
    h = math.pi / 2
    return Arm(
        tuple(
            Joint(convention="modified", alpha_rad=al, a_mm=a, d_mm=d, beta_rad=b)
            for al, a, d, b in (
                (0.0, 0.0, 210.0, None),
                (h, 24.0, 0.0, None),
                (0.001, 260.0, 0.5, 0.002),
                (-0.0005, 260.0, 1.0, -0.001),
                (h, 12.0, 80.0, None),
            )
        ),
        "z",
        (0.0, 0.0, 95.0),
    )


def encoders(arm: Arm) -> core.EncoderConfig:
    """Encoders of assorted resolutions, offsets and directions, one per joint."""
    n = arm.n_joints
    cpr = (1 << 32, 1 << 24, 3_600_000, 1 << 20, 1 << 32, 1 << 18, 1 << 32)[:n]
    zero = (0, 12345, 77, 1 << 19, 5, 99, 1 << 31)[:n]
    direction = (1, -1, 1, 1, -1, 1, -1)[:n]
    return core.EncoderConfig(cpr, zero, direction)


def reference(
    arm: Arm, enc: core.EncoderConfig, counts: tuple[int, ...]
) -> tuple[np.ndarray, np.ndarray]:
    """Point and 3 x P Jacobian from aacmm.core in double precision."""
    theta = core.counts_to_angles(np.array([counts], dtype=np.int64), enc)[0]
    return core.Model(arm).point_jacobian(theta)


def check_compute(client: Client, arm: Arm, enc: core.EncoderConfig, n: int, seed: int) -> float:
    rng = random.Random(seed)
    worst = 0.0
    for i in range(n):
        counts = tuple(rng.randrange(c) for c in enc.counts_per_rev)
        r = client.compute(counts, jacobian=i % 4 == 0)
        assert r.status & SampleStatus.POINT_VALID
        assert r.params == arm.n_params
        p, jac = reference(arm, enc, counts)
        worst = max(worst, float(np.max(np.abs(np.array(r.point_mm) - p))))
        if r.jacobian is not None:
            j = np.asarray(r.jacobian)
            assert j.shape == jac.shape == (3, arm.n_params)
            assert np.allclose(j, jac, rtol=1e-4, atol=1e-3)
    assert worst < FLOAT_PATH_BOUND_MM
    return worst


@pytest.fixture(scope="module")
def sim() -> Iterator[Sim]:
    s = Sim("--serial", "pty", "--motion", "walk", "--seed", "3")
    yield s
    assert s.stop() == 0, s.stderr_lines


@pytest.fixture
def client(sim: Sim) -> Iterator[Client]:
    with connect(sim.serial_url, timeout=2.0, retries=2) as c:
        yield c
        c.restore_defaults()


@pytest.mark.parametrize("make", [arm7, arm5], ids=["7-axis", "5-axis"])
def test_arm_over_the_wire(client: Client, make: object) -> None:
    assert callable(make)
    arm: Arm = make()
    enc = encoders(arm)
    ps = ParamSet.from_arm(arm, enc)
    assert ps.joints == arm.n_joints and ps.n_params == arm.n_params
    crc = client.set_params(ps)
    info = client.info()
    assert (info.joints, info.params, info.param_crc32) == (
        arm.n_joints,
        arm.n_params,
        crc,
    )
    back = client.get_params()
    assert back == ps
    arm_back, enc_back = back.to_arm()
    assert arm_back == arm and enc_back == enc

    check_compute(client, arm, enc, 40, seed=arm.n_joints)

    # samples: the device's own readings (the simulator's encoders have 2^32
    # counts per revolution), recomputed on the host
    enc = core.EncoderConfig((1 << 32,) * arm.n_joints, enc.zero_offset_counts, enc.direction)
    client.set_params(ParamSet.from_arm(arm, enc))
    s = client.measure(jacobian=True)
    assert len(s.counts) == arm.n_joints and s.params == arm.n_params
    assert s.status & SampleStatus.POINT_VALID
    p, jac = reference(arm, enc, s.counts)
    assert np.max(np.abs(np.array(s.point_mm) - p)) < FLOAT_PATH_BOUND_MM + 1e-4  # wire unit
    assert s.jacobian is not None
    assert np.allclose(np.asarray(s.jacobian), jac, rtol=1e-4, atol=1e-3)
    got = 0
    with client.stream(200, jacobian=True) as samples:
        deadline = time.monotonic() + 10
        for smp in samples:
            assert len(smp.counts) == arm.n_joints
            p, jac = reference(arm, enc, smp.counts)
            assert np.max(np.abs(np.array(smp.point_mm) - p)) < FLOAT_PATH_BOUND_MM + 1e-4
            assert smp.jacobian is not None
            assert np.allclose(np.asarray(smp.jacobian), jac, rtol=1e-4, atol=1e-3)
            got += 1
            if got == 30 or time.monotonic() > deadline:
                break
    assert got == 30


def test_counts_of_another_joint_count_are_refused(client: Client) -> None:
    arm = arm7()
    client.set_params(ParamSet.from_arm(arm))
    with pytest.raises(DeviceError) as ei:
        client.compute((1, 2, 3, 4, 5, 6))  # the paper's six
    assert ei.value.status == Status.ERR_RANGE
    client.restore_defaults()
    assert client.info().joints == 6
    with pytest.raises(DeviceError):
        client.compute((1, 2, 3, 4, 5, 6, 7))


def test_bad_sets_are_refused(client: Client) -> None:
    """The device validates the model: values out of range are refused; a 7-axis
    set with the thermal block is taken by the simulator, which reads link
    temperatures (its refusal on a device without sensors:
    test_loopback_errmodel.py)."""
    ps = ParamSet.from_arm(arm7())
    with pytest.raises(DeviceError) as ei:
        client.set_params(ParamSet(**{**ps.__dict__, "d_mm": (2e4, *ps.d_mm[1:])}))
    assert ei.value.status == Status.ERR_RANGE
    assert client.info().joints == 6  # still the defaults
    thermal = ParamSet(**{**ps.__dict__, "cte": (2300,) * 7, "ref_temp": 2000})
    client.set_params(thermal)
    assert client.get_params() == thermal and client.info().joints == 7


def test_param_set_option_and_storage_across_restart(tmp_path: Path) -> None:
    arm = arm5()
    enc = encoders(arm)
    ps = ParamSet.from_arm(arm, enc)
    f = tmp_path / "arm5.bin"
    f.write_bytes(encode_param_set(ps))
    with (
        Sim("--serial", "pty", "--param-set", str(f), "--motion", "static") as s,
        connect(s.serial_url, timeout=2.0) as c,
    ):
        info = c.info()
        assert (info.joints, info.params, info.param_source) == (5, arm.n_params, 0)
        assert c.get_params() == ps
        check_compute(c, arm, enc, 10, seed=1)
    a7 = arm7()
    store = tmp_path / "store.bin"
    ps7 = ParamSet.from_arm(a7, encoders(a7))
    with (
        Sim("--serial", "pty", "--storage", str(store)) as s,
        connect(s.serial_url, timeout=2.0) as c,
    ):
        c.set_params(ps7)
        crc = c.save_params()
    with (
        Sim("--serial", "pty", "--storage", str(store)) as s,
        connect(s.serial_url, timeout=2.0) as c,
    ):
        info = c.info()
        assert (info.joints, info.param_crc32, info.param_source) == (7, crc, 1)
        assert c.get_params() == ps7
        check_compute(c, a7, encoders(a7), 10, seed=2)


def test_bad_param_set_file_is_one_clear_line(tmp_path: Path) -> None:
    f = tmp_path / "bad.bin"
    f.write_bytes(encode_param_set(ParamSet.from_arm(arm7()))[:-1])
    r = subprocess.run(
        [str(SIM_BIN), "--serial", "pty", "--param-set", str(f)],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert r.returncode == 2  # usage (docs/simulator.md)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "not a parameter set this device takes (bad length)" in lines[0]


def _v1_body(t: int, seq: int, payload: bytes = b"", version: int = 1) -> bytes:
    return bytes([version, t, seq]) + payload


@pytest.mark.parametrize("version", [1, 2, 3])
def test_old_host_gets_a_version_error_it_can_read(sim: Sim, version: int) -> None:
    """A version 1, 2 or 3 host's request is answered with ERROR_RSP ERR_VERSION
    encoded in its own version (read here as such a decoder would: version byte,
    type 0xFF, seq echoed, i16 status, u8 request type)."""
    import serial

    assert sim.serial_path is not None
    with serial.Serial(sim.serial_path, timeout=0.2) as port:
        port.reset_input_buffer()
        port.write(encode_frame(_v1_body(0x01, 0x5A, struct.pack("<I", 0x1234), version)))
        port.write(encode_frame(_v1_body(0x02, 0x5B, version=version)))
        d = Deframer()
        bodies: list[bytes] = []
        deadline = time.monotonic() + 5
        while len(bodies) < 2 and time.monotonic() < deadline:
            bodies += d.feed(port.read(256))
    assert len(bodies) == 2
    for body, seq, req in zip(bodies, (0x5A, 0x5B), (0x01, 0x02), strict=True):
        assert body[0] == version and body[1] == 0xFF and body[2] == seq
        status, rtype = struct.unpack("<hB", body[3:])
        assert (status, rtype) == (int(Status.ERR_VERSION), req)
        # and the version 4 decoder names the version it saw
        with pytest.raises(FrameError) as ei:
            decode_message(body)
        assert ei.value.status == Status.ERR_VERSION and ei.value.version == version


@pytest.mark.parametrize("version", [1, 2, 3])
def test_new_host_gets_a_clear_version_error_from_an_old_device(version: int) -> None:
    """A version 1, 2 or 3 device answers every version 4 request with its own
    ERROR_RSP ERR_VERSION (its version byte): the client raises one clear
    DeviceError at once, naming the device's version, instead of timing out."""
    srv = SerialFakeServer()

    def old_device(body: bytes) -> list[object]:
        payload = struct.pack("<hB", -16, body[1])
        srv.send_raw(encode_frame(_v1_body(0xFF, body[2], payload, version)))
        return []

    srv.device.handle = old_device  # type: ignore[method-assign,assignment]
    try:
        with connect(srv.url, timeout=2.0, retries=0) as c:
            t0 = time.monotonic()
            with pytest.raises(DeviceError) as ei:
                c.info()
            assert time.monotonic() - t0 < 1.5  # not the timeout
            assert ei.value.status == Status.ERR_VERSION
            text = str(ei.value)
            assert f"protocol version {version} (" in text
            assert f"version {PROTOCOL_VERSION}: update the device's firmware" in text
            if version == 3:
                assert (
                    "the device speaks protocol version 3 (before device temperatures); this "
                    "host speaks version 4: update the device's firmware"
                ) in text
            assert ei.value.request_type == MsgType.INFO_REQ
    finally:
        srv.close()
