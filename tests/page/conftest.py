"""Fixtures shared by the page tests (tests/page/).

Each test file imports the module-scoped fixtures of test_page.py it needs (``server``,
``browser``, ``page_errors``, ``context`` or a context of its own), so each file has its own
service and browser context; the ``page`` on that context is defined here once.
"""
from __future__ import annotations

import pytest

from test_page import _open


@pytest.fixture(scope="module")
def page(context, server, page_errors):
    """A page of the module's ``context`` on the module's ``server``, ready, with every panel
    shown (the "all" view); closed after the module's tests."""
    p = _open(context, server, page_errors)
    yield p
    p.close()
