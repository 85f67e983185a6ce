"""The aacmm device client: one API over serial, SocketCAN and the virtual CAN bus.

>>> from aacmm.client import connect
>>> with connect("serial:///dev/pts/3") as arm:          # doctest: +SKIP
...     print(arm.info())
...     sample = arm.measure()
...     with arm.stream(1000) as samples:
...         for s in samples:
...             ...

URL forms are listed in :mod:`aacmm.transport`; without a URL, :func:`connect`
uses the ``AACMM_PORT`` environment variable.

Requests carry a sequence number the device echoes; a response is taken only
if its number and its type fit the waiting request, so a late answer to an
earlier, timed-out attempt (or to another program's request on the same line)
is never taken for the answer to a later one: it is counted in
``stats.stale_responses`` and ignored.
Each request waits ``timeout`` seconds; idempotent requests (ping, info, get
parameters, measure, compute, stream start/stop) are retried up to
``retries`` times after a timeout or a busy device, the others (set, save and
restore parameters) never, so they are not applied twice.

Errors (all but ``ValueError``/``TypeError`` derive from
:class:`aacmm.errors.AacmmError`):

- :class:`~aacmm.errors.InitError`: the port or bus cannot be opened; its
  subclass :class:`~aacmm.errors.VersionMismatchError`: the handshake
  (:meth:`Client.handshake`, ``connect(handshake=True)``) found another
  protocol version (in the info, as ERR_VERSION, or as answers the host drops
  for their version byte);
- :class:`~aacmm.errors.DeviceTimeoutError`: no answer in time (after retries);
- :class:`~aacmm.errors.DeviceError`: the device answered with an error
  response (``status`` is its ``aacmm_status_t``);
- :class:`~aacmm.errors.FrameError`: a ping answered with another token
  (invalid frames on the link are dropped and counted, never raised);
- :class:`~aacmm.errors.OperationError`: the client is closed or the link was
  lost;
- ``ValueError``/``TypeError``: bad arguments (checked before anything is sent).

The parts: :mod:`aacmm.client.connection` (:class:`Client`, :func:`connect`),
:mod:`aacmm.client.stream` (:class:`SampleStream`) and
:mod:`aacmm.client.options` (defaults, limits, :func:`check_timeout`); import
them from here. :mod:`aacmm.client.devstate` puts a device's state (info and
diagnostics) in words and JSON-ready data (``aacmm info``, log sidecars).
"""

from aacmm.client.connection import Client, ClientStats, connect
from aacmm.client.options import (
    DEFAULT_RETRIES,
    DEFAULT_TIMEOUT,
    ENV_PORT,
    IDEMPOTENT_REQUESTS,
    TIMEOUT_MAX,
    check_timeout,
)
from aacmm.client.options import TRIGGER_QUEUE as TRIGGER_QUEUE
from aacmm.client.stream import SampleStream, StreamStats
from aacmm.client.stream import device_time_after as device_time_after
from aacmm.client.stream import step_is_newer as step_is_newer

__all__ = [
    "DEFAULT_RETRIES",
    "DEFAULT_TIMEOUT",
    "ENV_PORT",
    "IDEMPOTENT_REQUESTS",
    "TIMEOUT_MAX",
    "Client",
    "ClientStats",
    "SampleStream",
    "StreamStats",
    "check_timeout",
    "connect",
]
