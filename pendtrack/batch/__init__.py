"""Batches of run-coded videos: names, resuming, executors, summary and the two-cuboid check.

* :mod:`pendtrack.batch.runcode` parses run codes (``06na5``) and lists a folder's videos;
* :mod:`pendtrack.batch.resume` writes and checks each run's ``done.json`` marker;
* :mod:`pendtrack.batch.worker` is what runs in a worker around the per-run job (log, done marker);
* :mod:`pendtrack.batch.executor` runs tasks on local processes or a Dask cluster;
* :mod:`pendtrack.batch.summary` builds summary.parquet/csv from the run artifacts;
* :mod:`pendtrack.batch.twocuboid` fits eq. consistencycheck to Omega0(l1);
* :mod:`pendtrack.batch.campaign` ties them together: :func:`~pendtrack.batch.campaign.run_campaign`
  plans, resumes, runs and summarises a folder's runs (the batch's one core call).

The stage :func:`pendtrack.stages.batch.batch_stage` calls it and writes the batch's files; the
per-run job (the pipeline's stages) is :func:`pendtrack.stages.batch_job.pipeline_job`:
``batch`` never imports ``stages``. Process pools and thread limits come from
:mod:`pendtrack.parallel`. Nothing heavy is imported here.
"""

from pendtrack.batch.runcode import RunCode, RunCodeError, parse_run_code

__all__ = ["RunCode", "RunCodeError", "parse_run_code"]
