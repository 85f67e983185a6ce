"""The exception tree of the aacmm host package.

Every error the package raises on purpose derives from :class:`AacmmError`, so
callers can catch that one class. Bad arguments raise the built-in
:class:`ValueError` (or :class:`TypeError`) instead.
"""

from __future__ import annotations


class AacmmError(Exception):
    """Base class of every aacmm error."""


class InitError(AacmmError):
    """A device, port or bus could not be opened or configured."""


class PortBusyError(InitError):
    """Another process or connection holds the port (the serial transport opens
    it exclusively, so two clients never share a link)."""


class VersionMismatchError(InitError):
    """The device speaks another protocol version, or announces a protocol
    version its INFO does not match (``aacmm`` exit status 5)."""


class OperationError(AacmmError):
    """An operation failed on the host side (I/O error, closed port, ...)."""


class LinkLostError(OperationError):
    """The link went away in the middle of an operation (device gone, port
    closed, samples stopped; ``aacmm`` exit status 6)."""


class DeviceTimeoutError(AacmmError):
    """The device did not answer in time."""


class FrameError(AacmmError):
    """Received bytes are not a valid frame or message.

    ``status`` is the matching firmware status code (``aacmm_status_t``, e.g.
    -5 for a CRC mismatch), so host and device report the same reason;
    ``version`` the version byte of a body of another protocol version.
    """

    def __init__(self, message: str, status: int, version: int | None = None) -> None:
        super().__init__(message)
        self.status = status
        self.version = version
        """For ERR_VERSION: the protocol version byte the body carried."""


class DeviceError(AacmmError):
    """The device answered a request with an error response.

    ``status`` is the device's ``aacmm_status_t`` code (negative) and
    ``request_type`` the message type of the failed request.
    """

    def __init__(self, message: str, status: int, request_type: int = 0) -> None:
        super().__init__(message)
        self.status = status
        self.request_type = request_type


class InfeasibleError(AacmmError):
    """The request is valid but no solution meets it (e.g. a tolerance target
    tighter than the best parts and encoders allow); exit status 8."""


class SourceFileError(AacmmError, ValueError):
    """A text file (an arm model, a plan) whose content breaks its schema, with
    the place: the message is one line, ``FILE:LINE: FIELD: problem`` (the line
    and the field where known); the parts are also in :attr:`file`,
    :attr:`line` (None if unknown), :attr:`field` (``""`` if none) and
    :attr:`problem`."""

    def __init__(self, file: str, line: int | None, field: str, problem: str) -> None:
        where = f"{file}:{line}" if line is not None else file
        super().__init__(f"{where}: {field}: {problem}" if field else f"{where}: {problem}")
        self.file = file
        self.line = line
        self.field = field
        self.problem = problem


class ModelError(SourceFileError):
    """An arm model (``aacmm.models``, schema ``aacmm-model-1``) that cannot be
    read, breaks the schema, or does not match the data it is used with.

    The message is one line, ``FILE:LINE: FIELD: problem`` (the line and the
    field where known); the parts are also in :attr:`file`, :attr:`line`
    (None if unknown) and :attr:`field` (``""`` if none). Exit status 2
    (a bad input file).
    """
