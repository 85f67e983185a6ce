"""aacmm host package: device client, logging and error analysis for articulated arm CMMs."""

__version__ = "0.1.0"
