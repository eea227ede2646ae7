"""Keep numba's on-disk cache consistent with the package's sources.

numba keys a cached function on its own source file only. The compiled core
(:func:`pneucore.integrator.integrate`) links code from ``rhs``, ``flow``,
``valve``, ``chamber``, ``heat``, ``jack``, ``friction`` and ``layout``, so
after an edit of ``flow.py`` alone numba would load a stale ``integrate``
from its cache and the edit would have no effect. At import,
:func:`check` compares a hash of every module of the package with a stamp
kept in the cache directory; on a mismatch it removes pneucore's cache
entries, and the next call compiles afresh (about 10 s of CPU time).
"""
import hashlib
import os

STAMP = "pneucore-sources.sha256"


def _sources_hash(pkg_dir):
    h = hashlib.sha256()
    for name in sorted(os.listdir(pkg_dir)):
        if name.endswith(".py"):
            h.update(name.encode())
            with open(os.path.join(pkg_dir, name), "rb") as f:
                h.update(f.read())
    return h.hexdigest()


def _locate():
    """The cache directory numba uses for this package's functions (None if unknown)."""
    try:
        from numba.core import caching
    except ImportError:          # pragma: no cover
        return None
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    if impl is None:             # pragma: no cover - numba's internal layout changed
        return None
    for cls in impl._locator_classes:
        try:
            loc = cls.from_function(_locate, os.path.abspath(__file__))
        except Exception:        # pragma: no cover - a locator that does not apply here
            continue
        if loc is not None:
            try:
                loc.ensure_cache_path()
            except OSError:
                continue
            return loc.get_cache_path()
    return None


def check(pkg_dir=None, cache_dir=None):
    """Drop pneucore's numba cache entries if any source file changed since they were written.

    Parameters
    ----------
    pkg_dir : str or None  Directory of the sources (default: this package)
    cache_dir : str or None  numba's cache directory for them (default: as numba locates it)

    Returns
    -------
    removed : int  Number of cache files removed (-1 when the cache could not be checked)
    """
    try:
        path = cache_dir or _locate()
        if path is None:
            return -1
        digest = _sources_hash(pkg_dir or os.path.dirname(os.path.abspath(__file__)))
        stamp = os.path.join(path, STAMP)
        try:
            with open(stamp) as f:
                if f.read().strip() == digest:
                    return 0
        except OSError:
            pass
        removed = 0
        for name in os.listdir(path):
            if name.endswith((".nbi", ".nbc")):
                try:
                    os.remove(os.path.join(path, name))
                    removed += 1
                except OSError:
                    pass
        tmp = f"{stamp}.{os.getpid()}"
        with open(tmp, "w") as f:
            f.write(digest)
        os.replace(tmp, stamp)
        return removed
    except OSError:
        return -1
