"""Self-contained HTML reports: the paper's figures for a run folder or a batch folder.

Layers, from the data to the page:

* :mod:`pendtrack.report.load` reads whatever artifacts a folder holds (a missing or broken
  one becomes a note on the page, never a crash);
* :mod:`pendtrack.report.derive` turns artifacts into the arrays a figure needs (turning
  points, model curves of Delta alpha, ...), calling :mod:`pendtrack.kinematics` for the physics;
* :mod:`pendtrack.report.figures` and :mod:`pendtrack.report.batch_figures` are pure functions
  from arrays to a :class:`matplotlib.figure.Figure` (Agg, no pyplot);
* :mod:`pendtrack.report.run_report` and :mod:`pendtrack.report.batch_report` arrange figures,
  tables and captions into a :class:`pendtrack.report.html.Page`;
* :mod:`pendtrack.report.html` writes the page as one HTML file with every image embedded as a
  PNG data URI, inline CSS, no script and a Content-Security-Policy that forbids any request.

The stage entry points (``report_stage``, ``write_run_report``, ``write_batch_report``) live in
:mod:`pendtrack.stages.report`. Nothing here is imported at package import time.
"""
