"""The diagnosis as a pipeline of named stages (:mod:`.stages`), its acceptance rules as one
list (:mod:`.rules`), the evidence beside the likelihood ratio (:mod:`.evidence`) and the
findings (:mod:`.findings`); :func:`pneucore.analysis.diagnose.diagnose` runs them."""
