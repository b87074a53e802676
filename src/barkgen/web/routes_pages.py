"""The web app's pages: the library (``/``), an exemplar and a result. Each is a static HTML file
whose script loads its data from the JSON API and says itself when an id is unknown."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import FileResponse

from barkgen.web.state import STATIC

router = APIRouter()


@router.get("/", include_in_schema=False)
def index_page():
    return FileResponse(STATIC / "index.html")


@router.get("/exemplars/{exemplar_id}", include_in_schema=False)
def exemplar_page(exemplar_id: str):
    return FileResponse(STATIC / "exemplar.html")


@router.get("/results/{result_id}", include_in_schema=False)
def result_page(result_id: str):
    return FileResponse(STATIC / "result.html")
