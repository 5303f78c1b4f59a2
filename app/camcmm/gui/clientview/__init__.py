"""The client-rendered 3-D view, Python side: a page's pyvista scene exported as layers
(:mod:`.export`), their buffers served by content hash (:mod:`.store`), the state and the
browser's triggers (:mod:`.client`), the trame element, toggle and triggers
(:mod:`.widget`) and the Inspect and Compare pages' hooks (:mod:`.hooks`). The browser
side is resources/ui/cloudview.js; the protocol between them is in docs/bigclouds.md."""

from .client import ClientView, checked_selection
from .export import Layer, Scene, export_scene, lod_order
from .hooks import CLIENT_LIMIT, attach_compare, attach_scene_view
from .store import BufferStore, buffer_name
from .widget import ROUTE, ClientViews, client_views, cloud_view, render_switch

__all__ = [
    "CLIENT_LIMIT",
    "ROUTE",
    "BufferStore",
    "ClientView",
    "ClientViews",
    "Layer",
    "Scene",
    "attach_compare",
    "attach_scene_view",
    "buffer_name",
    "checked_selection",
    "client_views",
    "cloud_view",
    "export_scene",
    "lod_order",
    "render_switch",
]
