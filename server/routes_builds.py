"""Build routes: a world built from an uploaded video (multipart), followed by its job id.

    curl -F video=@video.mp4 -F camera=@camera.json http://127.0.0.1:8000/v1/builds     -> 202 {"build_id", ...}
    curl http://127.0.0.1:8000/v1/builds/b-...                                            -> {"state", "progress", "world_id"}

Everything about the request is checked here, before a job exists: the
multipart form, a non-empty video part, a camera that ``world.io`` accepts,
the name. Size (413), upload time (408) and cross-origin uploads (403) are
the middleware's; the job count (429), the build's time and errors are
server/builds.py's.
"""

from __future__ import annotations

import json
from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import Response
from starlette.datastructures import UploadFile
from starlette.exceptions import HTTPException as StarletteHTTPException

from schemas import read_schema
from server.builds import BuildJobs, build_status_body
from server.contract import response_schema
from server.errors import json_response, note
from server.openapi_docs import ERROR_STATUSES, UPLOAD_ERROR_STATUSES, responses
from tools.errors import ToolError, echo, invalid_argument
from tools.registry import inline_refs
from world.io import camera_from_dict

router = APIRouter(tags=["builds"])

FORM_FIELDS = ("video", "camera", "name")
MAX_CAMERA_BYTES = 64 * 1024
UPLOAD_MEDIA_TYPE = "multipart/form-data"


def builds_of(request: Request) -> BuildJobs:
    """The BuildJobs (server.builds) of the app serving ``request``."""
    return request.app.state.builds


def build_form_schema() -> dict:
    """The multipart body of POST /v1/builds, for the OpenAPI document."""
    camera = inline_refs({"$ref": "world.schema.json#/$defs/camera"}, read_schema)
    return {
        "type": "object",
        "required": ["video", "camera"],
        "additionalProperties": False,
        "properties": {
            "video": {"type": "string", "format": "binary", "description": "the video file (mp4, h264)"},
            # An object part (sent as JSON, see the encoding below): a camera, bare or under a "camera" key.
            "camera": {"description": "the camera (a JSON part): bare, or under a 'camera' key as in a generator "
                                      "ground-truth file", "anyOf": [camera, {
                           "type": "object", "required": ["camera"], "properties": {"camera": camera}}]},
            "name": {"type": "string", "minLength": 1, "maxLength": 200, "description": "name of the world to register"},
        },
    }


def _invalid(pointer: str, message: str, expected: str) -> ToolError:
    return invalid_argument(None, pointer, message, expected)


async def _read_form(request: Request) -> tuple[bytes, dict, str | None]:
    media = request.headers.get("content-type", "").split(";", 1)[0].strip().lower()
    if media != UPLOAD_MEDIA_TYPE:
        raise ToolError(code="unsupported_media_type", tool=None, pointer="", status=415,
                        message=f"a build upload must be {UPLOAD_MEDIA_TYPE}, got {echo(media or 'no Content-Type')}",
                        expected="curl -F video=@video.mp4 -F camera=@camera.json")
    try:
        form = await request.form(max_files=2, max_fields=len(FORM_FIELDS), max_part_size=MAX_CAMERA_BYTES)
    except StarletteHTTPException as error:  # malformed multipart
        raise _invalid("", f"the multipart body cannot be read: {str(error.detail)[:200]}",
                       "a multipart/form-data body with parts video, camera (and name)") from None
    for key in form.keys():
        if key not in FORM_FIELDS:
            raise _invalid(f"/{key[:80]}", f"unknown form field {echo(key)}", f"only {list(FORM_FIELDS)}")
    video, camera_part, name = form.get("video"), form.get("camera"), form.get("name")
    if not isinstance(video, UploadFile):
        raise _invalid("/video", "the video must be a file part" if video is not None else "the video part is missing",
                       "a file part named video (curl -F video=@video.mp4)")
    data = await video.read()
    if not data:
        raise _invalid("/video", "the video file is empty", "a non-empty video file")
    camera_text = (await camera_part.read()) if isinstance(camera_part, UploadFile) else camera_part
    if camera_text is None:
        raise _invalid("/camera", "the camera part is missing", "a camera JSON (curl -F camera=@camera.json)")
    try:
        camera = json.loads(camera_text)
    except (ValueError, UnicodeDecodeError) as error:
        raise ToolError(code="invalid_json", tool=None, pointer="/camera", status=422,
                        message=f"the camera is not valid JSON: {str(error)[:200]}", expected="a camera JSON object") from None
    try:
        camera_from_dict(camera)
    except (ValueError, TypeError, KeyError) as error:
        raise _invalid("/camera", str(error)[:300], "a camera: width, height, fx, fy, cx, cy, position, rotation") from None
    if name is not None and (not isinstance(name, str) or not 0 < len(name) <= 200):
        raise _invalid("/name", "name must be a string of 1..200 characters", "a string of 1..200 characters")
    return data, camera, name


@router.post("/v1/builds", operation_id="create_build", status_code=202,
             responses=responses(202, response_schema("build_status"), "the build job was queued; poll its status",
                                 errors=(*ERROR_STATUSES, *UPLOAD_ERROR_STATUSES)),
             openapi_extra={"requestBody": {"required": True, "content": {UPLOAD_MEDIA_TYPE: {
                 "schema": build_form_schema(), "encoding": {"video": {"contentType": "application/octet-stream"},
                                                          "camera": {"contentType": "application/json"}}}}}})
async def create_build(request: Request) -> Response:
    video, camera, name = await _read_form(request)
    record = builds_of(request).submit(video, camera, name)
    note(request, build_id=record["build_id"])
    return json_response(build_status_body(record), 202, headers={"Location": f"/v1/builds/{record['build_id']}"})


@router.get("/v1/builds", operation_id="list_builds", responses=responses(200, response_schema("build_list")))
def list_builds(request: Request) -> Response:
    return json_response({"builds": [build_status_body(r) for r in builds_of(request).records()]})


@router.get("/v1/builds/{build_id}", operation_id="get_build", responses=responses(200, response_schema("build_status")))
def get_build(request: Request, build_id: str) -> Response:
    body: dict[str, Any] = build_status_body(builds_of(request).status(build_id))
    return json_response(body)
