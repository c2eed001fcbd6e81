"""The least-squares machinery under the fit's five steps.

The record of a fit and its residuals on a window (:mod:`.samples`, :mod:`.problem`), the
paper's cost and the data's filter (:mod:`.cost`), the equation-error estimates that start it
(:mod:`.equation_error`), the Levenberg-Marquardt solver (:mod:`.lm`) in decorrelated
coordinates (:mod:`.coordinates`), one start's local fit and the parallel task runner
(:mod:`.local_fits`), the starts window by window (:mod:`.ladder`), and the profile polish and
profile sigmas (:mod:`.profile`). The steps on top (:mod:`pendtrack.fitting.estimate`, ...)
use these; nothing here reads or writes files.
"""
