"""Transports of the aacmm client and the device URL syntax.

Accepted URL forms (:func:`parse_url`, :func:`open_transport`):

==========================================  ===========================================
``serial:///dev/ttyACM0``                   serial device or pseudo-terminal (path)
``serial:///dev/ttyACM0?baud=115200``       ... with a line rate (default 921600)
``serial://COM3``                           Windows port name
``serial://socket://host:port``             any pyserial URL after ``serial://``,
``serial://rfc2217://host:port``            passed to ``serial_for_url`` unchanged
``serial://loop://``                        (query included)
``/dev/ttyUSB0``, ``COM3``                  a bare path or port name is serial too
``socket://host:port``, ``rfc2217://...``,  bare pyserial URLs are serial too
``loop://``, ``spy://...``
``socketcan://vcan0?node=1``                SocketCAN interface, device CAN node 0..15
``socketcan://can0?node=3&isotp=user``      ... with the user-space ISO-TP stack
``virtual://name?node=1``                   python-can's in-process virtual bus
==========================================  ===========================================

CAN URLs take ``node`` (default 1, the simulator's default) and
``isotp_timeout_ms`` (default 1000) in the query; SocketCAN URLs also
``isotp=auto|kernel|user`` (default ``auto``: the kernel's ISO-TP sockets
when the kernel has them, else the user-space ``can-isotp`` stack).

Errors (:mod:`aacmm.errors`): :class:`~aacmm.errors.InitError` (cannot open
or configure the port or bus) and its subclass
:class:`~aacmm.errors.PortBusyError`, :class:`~aacmm.errors.OperationError`
(I/O on a closed or failed link), :class:`~aacmm.errors.DeviceTimeoutError`
(no ISO-TP answer in time), :class:`~aacmm.errors.FrameError` (bytes that are
not a valid frame); ``ValueError`` for a bad URL or argument.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final
from urllib.parse import parse_qsl, urlsplit

from aacmm.transport.base import Sink, Transport, TransportStats
from aacmm.transport.canbus import (
    CanTransport,
    SampleFrameDecoder,
    SocketCanTransport,
    VirtualCanTransport,
)
from aacmm.transport.serialport import DEFAULT_BAUDRATE, SerialTransport

__all__ = [
    "DEFAULT_BAUDRATE",
    "DEFAULT_CAN_NODE",
    "CanTransport",
    "SampleFrameDecoder",
    "SerialTransport",
    "Sink",
    "SocketCanTransport",
    "Transport",
    "TransportStats",
    "TransportUrl",
    "VirtualCanTransport",
    "open_transport",
    "parse_url",
]

DEFAULT_CAN_NODE: Final = 1
_PYSERIAL_SCHEMES: Final = frozenset(
    {"socket", "rfc2217", "loop", "spy", "hwgrep", "alt", "cp2110"}
)


@dataclass(frozen=True)
class TransportUrl:
    """A parsed device URL: ``kind`` is ``"serial"``, ``"socketcan"`` or ``"virtual"``.

    ``target`` is the serial port / pyserial URL or the CAN channel;
    ``baudrate`` applies to serial, ``node`` and ``isotp_timeout_ms`` to CAN.
    """

    kind: str
    target: str
    baudrate: int = DEFAULT_BAUDRATE
    node: int = DEFAULT_CAN_NODE
    isotp_timeout_ms: int = 1000
    isotp: str = "auto"


def _int(name: str, text: str, lo: int, hi: int) -> int:
    try:
        value = int(text, 0)
    except ValueError:
        raise ValueError(f"{name}={text!r} is not an integer") from None
    if not lo <= value <= hi:
        raise ValueError(f"{name}={value} outside {lo}..{hi}")
    return value


def parse_url(url: str) -> TransportUrl:
    """Parse a device URL (see the module docstring for the forms).

    Raises:
        ValueError: empty, unknown scheme, or a bad/unknown query parameter.
    """
    if not isinstance(url, str) or not url.strip():
        raise ValueError("empty device URL")
    url = url.strip()
    scheme, sep, rest = url.partition("://")
    if not sep:
        return TransportUrl("serial", url)  # bare path or port name
    scheme = scheme.lower()
    if scheme in _PYSERIAL_SCHEMES:
        return TransportUrl("serial", url)
    if scheme == "serial":
        inner_scheme, inner_sep, _ = rest.partition("://")
        if inner_sep and inner_scheme.lower() in _PYSERIAL_SCHEMES:
            return TransportUrl("serial", rest)
        path, _, query = rest.partition("?")
        if not path:
            raise ValueError(f"no serial port in {url!r}")
        baud = DEFAULT_BAUDRATE
        for key, value in parse_qsl(query, keep_blank_values=True):
            if key in ("baud", "baudrate"):
                baud = _int(key, value, 1, 100_000_000)
            else:
                raise ValueError(f"unknown serial URL parameter {key!r}")
        return TransportUrl("serial", path, baudrate=baud)
    if scheme in ("socketcan", "virtual"):
        parts = urlsplit(url)
        channel = parts.netloc or parts.path.lstrip("/")
        if not channel:
            raise ValueError(f"no CAN channel in {url!r}")
        node, tmo, tp = DEFAULT_CAN_NODE, 1000, "auto" if scheme == "socketcan" else "user"
        for key, value in parse_qsl(parts.query, keep_blank_values=True):
            if key == "node":
                node = _int(key, value, 0, 15)
            elif key == "isotp_timeout_ms":
                tmo = _int(key, value, 1, 60_000)
            elif key == "isotp" and scheme == "socketcan":
                if value not in ("auto", "kernel", "user"):
                    raise ValueError(f"isotp={value!r}: use auto, kernel or user")
                tp = value
            else:
                raise ValueError(f"unknown CAN URL parameter {key!r}")
        return TransportUrl(scheme, channel, node=node, isotp_timeout_ms=tmo, isotp=tp)
    raise ValueError(f"unknown URL scheme {scheme!r} in {url!r}")


def open_transport(url: str | TransportUrl, write_timeout: float = 2.0) -> Transport:
    """Open the transport a URL names (not yet started).

    Raises:
        ValueError: bad URL.
        InitError: the port or bus cannot be opened.
    """
    u = parse_url(url) if isinstance(url, str) else url
    if u.kind == "serial":
        return SerialTransport(u.target, baudrate=u.baudrate, write_timeout=write_timeout)
    if u.kind == "socketcan":
        return SocketCanTransport(
            u.target,
            u.node,
            isotp=u.isotp,
            isotp_timeout_ms=u.isotp_timeout_ms,
            send_timeout=write_timeout,
        )
    if u.kind == "virtual":
        return VirtualCanTransport(
            u.target, u.node, isotp_timeout_ms=u.isotp_timeout_ms, send_timeout=write_timeout
        )
    raise ValueError(f"unknown transport kind {u.kind!r}")
