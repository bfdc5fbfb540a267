"""Analysis: the statistics, the paper's findings beside ours, the paradigm effect beside another folder's."""
