"""Every subcommand of the ``aacmm`` tool (``aacmm.cli`` registers them).

- :mod:`aacmm.commands.device`: ``info``, ``params``, ``measure``, ``compute``
- :mod:`aacmm.commands.log`: ``log`` (the run: :mod:`aacmm.commands.logger`)
- :mod:`aacmm.commands.summary`: ``summary``
- :mod:`aacmm.commands.sim`: ``sim``
- :mod:`aacmm.commands.view`: ``view`` (on :mod:`aacmm.view`), and ``capture --view``
- :mod:`aacmm.commands.mc`: ``mc`` (on :mod:`aacmm.analysis.mc`)
- :mod:`aacmm.commands.uncertainty`: ``uncertainty`` (on :mod:`aacmm.uncertainty`)
- :mod:`aacmm.commands.exitcodes`: the exit statuses of every command
"""
