"""Keep numba's on-disk cache consistent with the package's sources.

numba keys a cached function on its own source file only. The compiled core
(:func:`pneucore.core.integrator.integrate`) links code from ``rhs``, ``flow``,
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
    """SHA-256 over every ``.py`` file under ``pkg_dir`` (subpackages included), by relative path."""
    h = hashlib.sha256()
    for path in _sources(pkg_dir):
        h.update(os.path.relpath(path, pkg_dir).replace(os.sep, "/").encode())
        with open(path, "rb") as f:
            h.update(f.read())
    return h.hexdigest()


def _sources(pkg_dir):
    """Every ``.py`` file under ``pkg_dir``, in a stable order (``__pycache__`` skipped)."""
    out = []
    for root, dirs, files in os.walk(pkg_dir):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        out += [os.path.join(root, f) for f in sorted(files) if f.endswith(".py")]
    return out


def _locate(source_dir=None):
    """The cache directory numba uses for functions defined in ``source_dir`` (None if unknown).

    numba keeps one cache directory per source directory (``__pycache__`` beside
    the file, or a mirror of its path under ``NUMBA_CACHE_DIR``), so each
    subpackage with compiled functions has its own.
    """
    source = os.path.join(source_dir, "__init__.py") if source_dir else os.path.abspath(__file__)
    try:
        from numba.core import caching
    except ImportError:          # pragma: no cover
        return None
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    if impl is None:             # pragma: no cover - numba's internal layout changed
        return None
    for cls in impl._locator_classes:
        try:
            loc = cls.from_function(_locate, source)
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
    pkg_dir : str or None
        Directory of the sources, walked with its subpackages (default: the pneucore package)
    cache_dir : str or None
        numba's cache directory for them (default: as numba locates it for each
        directory of the package; the stamp lives in the package root's)

    Returns
    -------
    removed : int
        Number of cache files removed (-1 when the cache could not be checked)
    """
    try:
        pkg = pkg_dir or os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        if cache_dir:
            dirs = [cache_dir]
        else:
            dirs = [_locate(d) for d in sorted({os.path.dirname(p) for p in _sources(pkg)})]
            if not dirs or dirs[0] is None:
                return -1
            dirs = [d for d in dirs if d]
        digest = _sources_hash(pkg)
        stamp = os.path.join(dirs[0], STAMP)
        try:
            with open(stamp) as f:
                if f.read().strip() == digest:
                    return 0
        except OSError:
            pass
        removed = 0
        for path in dict.fromkeys(dirs):
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
