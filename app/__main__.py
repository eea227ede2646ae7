"""``python -m app``: start the web service."""
from .main import main

if __name__ == "__main__":   # guarded: study worker processes (spawn) re-import the main module
    main()
