"""Reports: CSV tables (.tables), PNG figures (.plots), Markdown summaries (.markdown)."""
