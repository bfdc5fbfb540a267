"""Running the study: trials behind an executor into a study folder, and the record of one trial."""
