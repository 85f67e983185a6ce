"""Subcommands of the ``aacmm`` tool that talk to a device or the simulator.

- :mod:`aacmm.commands.device`: ``info``, ``params``, ``measure``, ``compute``
- :mod:`aacmm.commands.log`: ``log``, ``summary``
- :mod:`aacmm.commands.sim`: ``sim``
- :mod:`aacmm.commands.exitcodes`: the exit statuses of every command
"""
