"""``python -m twin.cli ARGS`` runs ``rfp-twin ARGS``."""
from twin.cli import main

main()
