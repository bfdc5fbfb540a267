"""Analysis: the statistics and the paper's findings beside ours."""
