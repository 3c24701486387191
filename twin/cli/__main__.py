"""``python -m rfp_twin.twin.cli ARGS`` runs ``rfp-twin ARGS``."""
from rfp_twin.twin.cli import main

main()
