"""One module per sub-command; the CLI discovers them."""
