"""The study's data: the study folder (records and traces appended and read back) and the
authors' logs as records."""
