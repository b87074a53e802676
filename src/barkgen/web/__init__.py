"""barkgen's web app: the exemplar library in the browser, one-click generation with live
progress, results on a WebGL trunk, a label painter and material-set downloads
(:func:`create_app`, :func:`serve`; ``barkgen serve`` on the command line)."""

from barkgen._shared.extras import require_extra

require_extra("web", "the web app (barkgen serve)")

from barkgen.web.app import WebLimits, create_app, serve  # noqa: E402

__all__ = ["WebLimits", "create_app", "serve"]
