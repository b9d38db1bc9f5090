"""A new job's request body, read without a framework: a JSON object (constants like NaN refused, nesting
that exhausts the parser refused) or multipart form data (the standard library's email parser). Anything
malformed is an `HttpError` with its one line."""

from __future__ import annotations

import json
from email.parser import BytesParser
from email.policy import HTTP


class HttpError(Exception):
    """A refusal: its status and the one line the client reads."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status


def json_object(data: bytes, what: str) -> dict:
    try:
        value = json.loads(data, parse_constant=_refuse_constant)
    except (ValueError, RecursionError) as error:
        raise HttpError(400, f"{what} is not JSON: {str(error).splitlines()[0][:120]}") from None
    if not isinstance(value, dict):
        raise HttpError(400, f"{what} must be a JSON object, got {type(value).__name__}")
    return value


def _refuse_constant(name: str):
    raise ValueError(f"{name} is not a number JSON allows")


def multipart_fields(content_type: str, body: bytes) -> tuple[dict, bytes | None]:
    """Fields `kind`, `options` (JSON text), `priority` and a `payload` file."""
    message = BytesParser(policy=HTTP).parsebytes(f"Content-Type: {content_type}\r\n\r\n".encode() + body)
    if not message.is_multipart() or message.defects:
        raise HttpError(400, "the multipart body is malformed (check its boundary)")
    fields, payload = {}, None
    for part in message.iter_parts():
        name = part.get_param("name", header="content-disposition")
        data = part.get_payload(decode=True) or b""
        if name == "payload":
            payload = data
        elif name in ("kind", "options", "priority"):
            try:
                text = data.decode("utf-8")
            except UnicodeDecodeError:
                raise HttpError(400, f"field {name!r} is not UTF-8 text") from None
            if name == "kind":
                fields[name] = text.strip()
            elif name == "options":
                fields[name] = json_object(data, "the field 'options'")
            else:
                try:
                    number = float(text)
                except ValueError:
                    raise HttpError(400, f"field {name!r} must be a number, got {text[:40]!r}") from None
                fields[name] = int(number) if number.is_integer() else number
        else:
            raise HttpError(400, f"unknown field {str(name)[:40]!r}: the fields are kind, options, priority and "
                                 "payload")
    return fields, payload
