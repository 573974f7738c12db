"""MkDocs hooks of the documentation site (mkdocs.yml ``hooks:``; not a page).

The docstrings cross-reference in Sphinx's roles (``:func:`~.start.start_model```), which
mkdocstrings shows as they are written; the API reference shows the name as code instead:
``start_model`` for ``~`` (the last part), the path without its leading dots otherwise.
"""

from __future__ import annotations

import re

#: a Sphinx role as mkdocstrings renders it: the role's name, then its target as code
ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|data|attr|exc|obj|const|term):"
                  r"<code>(~?)\.?([^<]+)</code>")


def plain_roles(html: str) -> str:
    """``:func:<code>~.a.b</code>`` → ``<code>b</code>``; ``:class:<code>a.B</code>`` →
    ``<code>a.B</code>``."""
    return ROLE.sub(lambda m: f"<code>{m[2].rsplit('.', 1)[-1] if m[1] else m[2]}</code>",
                    html)


def on_page_content(html, page, config, files):
    return plain_roles(html)
