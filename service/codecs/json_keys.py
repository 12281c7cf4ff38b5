"""Duplicate keys in a JSON body: refused, never "the last one wins".

The JSON parsers of the service (pydantic's, jiter) keep the last of two equal keys, so that
``"position": [NaN, 0, 0], "position": [0, 0, 0]`` would pass unseen. The check runs after a
body parsed and validated, in two steps:

1. **count** (:func:`check_no_duplicates`, ~1 us): every key of a JSON document is followed
   by a colon, and outside strings a colon follows nothing else; so when the body holds no
   more colons than the distinct keys the parser kept, no key was repeated.
2. **scan** (:func:`first_duplicate_key`), only when there are more colons (a repeated key,
   or a colon inside a string value): the document's strings and braces are tokenised by one
   regular expression, and each object's keys are compared. The body is valid JSON already,
   so every quote outside a string opens one, and the tokens stay aligned.
"""
from __future__ import annotations

import functools
import json
import re
import typing

from pydantic import BaseModel, ValidationError

from impactnet.service.errors import DuplicateKey, InputError, InvalidBody, ServiceError

#: A JSON string (escapes included), optionally followed by the colon that makes it a key; or
#: a brace that opens or closes an object.
_TOKENS = re.compile(rb'"(?:[^"\\]|\\.)*"(\s*:)?|[{}]', re.DOTALL)
#: A JSON string, escapes included.
_STRINGS = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)


@functools.cache
def _model_fields(model: type[BaseModel]) -> tuple[str, ...]:
    """Fields of ``model`` whose type is (or may be) a model."""
    return tuple(name for name, info in model.model_fields.items()
                 if any(isinstance(kind, type) and issubclass(kind, BaseModel)
                        for kind in (info.annotation, *typing.get_args(info.annotation))))


def distinct_keys(model: BaseModel) -> int:
    """Keys a validated pydantic model was given, nested models included (with
    ``extra="forbid"`` these are all the distinct keys of the body's objects). ~1 us for a
    pair: it runs on every request."""
    given = model.__pydantic_fields_set__  # what model_fields_set returns, without its cost
    count = len(given)
    for name in _model_fields(model.__class__):
        if name in given and isinstance(value := getattr(model, name), BaseModel):
            count += distinct_keys(value)
    return count


def _key(token: bytes) -> str:
    """A key's text (escapes decoded); its raw text where the escapes are invalid (a body
    that is not valid JSON is scanned before it is parsed when it has too many keys)."""
    try:
        return json.loads(token)
    except ValueError:
        return token[1:-1].decode("utf-8", "replace")


def first_duplicate_key(raw: bytes) -> str | None:
    """The first key repeated within one object of the JSON document ``raw``, as a dotted
    path (``"a.position"``), or None. Meant for valid JSON; anything else gives some answer
    without failing."""
    stack: list[tuple[set[str], str]] = []
    last_key = ""
    for match in _TOKENS.finditer(raw):
        token = match.group(0)
        if token == b"{":
            parent = stack[-1][1] if stack else ""
            prefix = f"{parent}.{last_key}" if parent and last_key else (last_key or parent)
            stack.append((set(), prefix if stack else ""))
            last_key = ""
        elif token == b"}":
            if stack:
                stack.pop()
            last_key = ""
        elif match.group(1) is not None and stack:
            key = _key(token[:token.rindex(b'"') + 1])
            seen, path = stack[-1]
            if key in seen:
                return f"{path}.{key}" if path else key
            seen.add(key)
            last_key = key
    return None


def validated_json(model, raw: bytes, content_type: str | None):
    """``model`` (a pydantic model class) parsed and validated from the JSON body ``raw`` in one
    pass (pydantic's strict JSON parser: no NaN / Infinity tokens, no numbers as strings;
    invalid UTF-8 is malformed JSON). A missing Content-Type counts as JSON; anything but JSON
    is 415, an invalid body 422 (:class:`InvalidBody`)."""
    media = (content_type or "application/json").split(";", 1)[0].strip().lower()
    if media != "application/json" and not media.endswith("+json"):
        raise ServiceError(415, "unsupported_media_type", f"Content-Type {media!r}; send "
                           "application/json")
    try:
        return model.model_validate_json(raw)
    except ValidationError as exc:
        raise InvalidBody(exc.errors(include_url=False, include_input=False)) from exc


def check_no_duplicates(raw: bytes, keys: int) -> None:
    """Raise :class:`impactnet.service.errors.DuplicateKey` (422, naming the key) when the valid
    JSON document ``raw``, whose parse kept ``keys`` distinct keys, repeats one."""
    if raw.count(b":") <= keys:
        return
    duplicate = first_duplicate_key(raw)
    if duplicate is not None:
        raise DuplicateKey(duplicate)


#: Key of a field's ``json_schema_extra`` that declares the most keys each item of a list of
#: free-form objects may hold (inline ``parts``: a part's schema lives in the scene parser).
ITEM_KEYS = "x-max-keys-per-item"


def _item_keys(info) -> int:
    """Keys a list-of-objects field may hold at most: its items times their declared keys."""
    extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
    per_item = extra.get(ITEM_KEYS, 0)
    if not per_item:
        return 0
    constraints = list(info.metadata)
    for arg in typing.get_args(info.annotation):  # Annotated[list[dict], Field(...)] | None
        for meta in getattr(arg, "__metadata__", ()):
            constraints += [meta, *getattr(meta, "metadata", ())]
    items = max((m.max_length for m in constraints if getattr(m, "max_length", None)),
                default=0)
    return per_item * items


@functools.cache
def known_keys(model: type[BaseModel]) -> int:
    """Keys a body of ``model`` can hold at most: its fields; for a field whose type is (or
    may be) a model, that model's keys; for a list of free-form objects, the keys it declares
    (:data:`ITEM_KEYS`) per item."""
    count = len(model.model_fields)
    for name in _model_fields(model):
        annotation = model.model_fields[name].annotation
        count += max(known_keys(kind) for kind in (annotation, *typing.get_args(annotation))
                     if isinstance(kind, type) and issubclass(kind, BaseModel))
    return count + sum(_item_keys(info) for info in model.model_fields.values())


def _colons_outside_strings(raw: bytes) -> int:
    return _STRINGS.sub(b"", raw).count(b":")


def validated_unique(model, raw: bytes, content_type: str | None):
    """:func:`validated_json`, then the duplicate-key check. A body with more keys than ``model``
    knows is refused first, unparsed (422 naming a repeated key, else ``too_many_keys``): validating
    thousands of unknown keys held the event loop's GIL for tens of milliseconds."""
    limit = known_keys(model)
    if raw.count(b":") > limit:
        keys = _colons_outside_strings(raw)
        if keys > limit:
            duplicate = first_duplicate_key(raw)
            if duplicate is not None:
                raise DuplicateKey(duplicate)
            raise InputError("body", f"{keys} keys; this request has at most {limit} (unknown "
                             "keys)", type_="too_many_keys")
    parsed = validated_json(model, raw, content_type)
    check_no_duplicates(raw, distinct_keys(parsed))
    return parsed
