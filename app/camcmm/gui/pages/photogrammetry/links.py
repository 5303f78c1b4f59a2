""" "Send to": the reconstructed cloud handed to another page, which is then shown.

- **Inspect**: the cloud becomes the item shown in the shared 3-D view (any plugin's
  form offers it first: a fit, a sphere extraction).
- **Compare with CAD**: the cloud is chosen as the measured cloud; the nominal stays as
  the operator chose it.
- **Acceptance test**: the page opens with the cloud named in its note; a position
  takes it by Import (the wizard records each position's own file).

Each target page is looked up among the mounted pages (``server.pages``): a page that
is not installed is a one-line refusal, not a crash.
"""

from __future__ import annotations

from typing import Any

from ....errors import InputError

#: target -> (page key, button text, tooltip)
TARGETS = {
    "inspect": ("inspect", "Inspect", "Show the cloud on the Inspect page (fits, extraction, any plugin)"),
    "compare": ("compare", "Compare with CAD", "Choose the cloud as the measured cloud on the Compare with CAD page"),
    "acceptance": (
        "acceptance",
        "Acceptance test",
        "Open the Acceptance test page to use the cloud at a position (VDI/VDE 2634-3)",
    ),
}


def buttons() -> list[dict[str, str]]:
    """The send-to buttons' rows (``value``, ``title``, ``tip``)."""
    return [{"value": k, "title": t, "tip": tip} for k, (_, t, tip) in TARGETS.items()]


def send(server: Any, session: Any, target: str, key: Any) -> str:
    """Hand item ``key`` to page ``target`` and switch to it; returns the page key."""
    if target not in TARGETS:
        raise InputError(f"send to {str(target)[:40]!r}: choose one of {', '.join(TARGETS)}")
    page_key, title, _ = TARGETS[target]
    pages = getattr(server, "pages", {}) or {}
    if page_key not in pages:
        raise InputError(f"send to {title}: that page is not installed in this app")
    if key is None or session.measurement(key) is None:
        raise InputError(f"send to {title}: no reconstructed cloud yet: run the reconstruction first")
    name = str(session.measurement(key).get("name") or key)
    state = session.state
    if target == "inspect":
        session.select_item(str(key))
    elif target == "compare":
        pages[page_key].set_inputs(measured=str(key))
    state.page = page_key
    state.main_drawer = page_key in (state.drawer_pages or [])
    if target == "acceptance":
        session.info(f"{name} is in the project: import it at the position it measured", page=page_key)
    else:
        session.info(f"{name} from the Photogrammetry page", page=page_key)
    return page_key
