"""One module per `farm analyse` command: load, fit, write tables, figures, summary
(:mod:`.common`: what they share)."""
