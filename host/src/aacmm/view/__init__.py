"""See the arm: a live 3-D view in the browser, offline views, HTML reports.

A pure library (no argparse, no printing); ``aacmm view`` and ``aacmm
capture --view`` (docs/view.md) are its commands.

* :mod:`aacmm.view.arm` -- the joints' frames of an n-joint DH chain
  (:func:`~aacmm.view.arm.arm_pose`, :class:`~aacmm.view.arm.ArmPose`);
* :mod:`aacmm.view.features` -- each step's fitted feature and every point's
  residual (:func:`~aacmm.view.features.step_features`);
* :mod:`aacmm.view.scene` -- what a page shows, for a session, a log, a
  verification or a calibration (format ``aacmm-view-1``);
* :mod:`aacmm.view.live` -- frames from the device's samples, a capture's
  progress (:class:`~aacmm.view.live.LiveFeed`); :mod:`aacmm.view.options` its
  settings' defaults and limits;
* :mod:`aacmm.view.capture` -- the live page beside a capture
  (:class:`~aacmm.view.capture.CaptureView`, :func:`~aacmm.view.capture.follow_capture`);
* :mod:`aacmm.view.server` -- the local web server
  (:class:`~aacmm.view.server.ViewServer`: the page, plotly.js from the
  installed ``plotly`` package, ``/scene.json``, a push WebSocket);
* :mod:`aacmm.view.html` -- one self-contained HTML file of a scene
  (:func:`~aacmm.view.html.standalone_html`).

The page is plotly.js (docs/view.md says why) and the page's own script in
``static/``; nothing is loaded from the network.

Errors (:mod:`aacmm.view.server`): :class:`~aacmm.view.server.ViewError` (an
:class:`aacmm.errors.AacmmError`: the view cannot be served) and
:class:`~aacmm.view.server.BindError` (an :class:`aacmm.errors.InitError`: the
address cannot be bound).
"""
