"""``python -m app``: start the web service."""
from .main import main

main()
