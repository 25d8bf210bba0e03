"""Make `fem_reference` importable when pytest is started from anywhere; quiet the JIT log."""
import logging
import os
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
logging.getLogger().setLevel(logging.WARNING)
