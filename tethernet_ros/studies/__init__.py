"""Studies of the model and of its numerical method over common random numbers:

=============  ==========================================================================
cells.py       what a study compares: its cells (a label and a configuration) per study
paired.py      statistics of two cells on the same samples: P*_s, Wilson intervals,
               flipped verdicts, mean T
report.py      the study's Markdown table and figure
summary.py     the study's summary file: every finished cell's statistics, run key and
               verdicts, from which a later run takes the cells up again
=============  ==========================================================================

``tethernet study NAME`` (commands/study.py) runs one.
"""
