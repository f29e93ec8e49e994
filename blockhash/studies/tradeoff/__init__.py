"""The trade study (speed against accuracy of the caustic layer, ``blockhash tradeoff``):
:mod:`.sweep` runs the settings and measures them, :mod:`.report` writes ``tradeoff.json``, the
plots and ``report.md``, :mod:`.claims` the study's claims, and :mod:`.budget` picks settings
for a time budget or a target error from a study."""
