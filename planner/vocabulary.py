"""The question language's vocabulary: attribute words, event nouns, operators.

One table per word class, so the grammar (``planner.grammar``) never spells a
word and the program compiler (``planner.parser``) never spells an operator
outside this module. Values follow CLEVRER (and DESIGN.md): eight colours, two
materials, three shapes.

The planner talks to the world only over HTTP, so these tables are spelled out
here rather than imported from ``world.types``; a test checks they agree.
"""

from __future__ import annotations

from typing import Literal, Mapping

AttributeKind = Literal["color", "material", "shape"]

COLORS: tuple[str, ...] = ("gray", "red", "blue", "green", "brown", "yellow", "cyan", "purple")
MATERIALS: tuple[str, ...] = ("metal", "rubber")
SHAPES: tuple[str, ...] = ("sphere", "cube", "cylinder")

# Surface word -> (attribute kind, canonical value): CLEVRER's spellings plus
# the plain words a new user writes for the same thing ("grey", "ball",
# "block", "metallic"). Each is unambiguous in a world of spheres, cubes and
# cylinders; nothing else is guessed.
ATTRIBUTE_WORDS: Mapping[str, tuple[AttributeKind, str]] = {
    **{color: ("color", color) for color in COLORS},
    "grey": ("color", "gray"),
    **{material: ("material", material) for material in MATERIALS},
    "metallic": ("material", "metal"),
    **{shape: ("shape", shape) for shape in SHAPES},
    "ball": ("shape", "sphere"),
    "block": ("shape", "cube"),
}

# Head nouns of an object phrase that carry no attribute ("the red object").
GENERIC_OBJECT_NOUNS: frozenset[str] = frozenset({"object", "thing"})

# The fixed order in which an object reference's filters are emitted,
# whatever the order of the adjectives in the text (CLEVRER's canonical form).
FILTER_ORDER: tuple[tuple[AttributeKind, str], ...] = (
    ("color", "filter_color"),
    ("material", "filter_material"),
    ("shape", "filter_shape"),
)

EventKind = Literal["collision", "in", "out"]

# Event kind -> the operator that selects it from an event list.
EVENT_FILTERS: Mapping[EventKind, str] = {
    "collision": "filter_collision",
    "in": "filter_in",
    "out": "filter_out",
}

# What may follow an event's subject ("the cube" or "the cube's"), as word
# sequences -> event kind. Nominal forms come from explanatory text ("the
# cube's entrance", "the cube's colliding with the sphere"); finite forms from
# predictive/counterfactual choices ("the cube collides with the sphere",
# "the cube enters the scene"). A collision phrase is followed by its second
# object.
# Plain-word paraphrases ("hits", "bumps into", "leaves the scene", "would")
# name the same events.
_COLLISION_VERBS: tuple[tuple[str, ...], ...] = (
    ("colliding", "with"), ("collides", "with"), ("collide", "with"), ("hits",), ("hit",), ("hitting",),
    ("bumps", "into"), ("bump", "into"), ("bumping", "into"), ("runs", "into"), ("run", "into"),
    ("crashes", "into"), ("crash", "into"),
)
_ENTER_VERBS: tuple[tuple[str, ...], ...] = (("enters", "the", "scene"), ("enter", "the", "scene"))
_EXIT_VERBS: tuple[tuple[str, ...], ...] = (
    ("exits", "the", "scene"), ("exit", "the", "scene"), ("leaves", "the", "scene"), ("leave", "the", "scene"),
)
FUTURE_MODALS: tuple[str, ...] = ("will", "would")


def _with_modals(verbs: tuple[tuple[str, ...], ...], kind: EventKind) -> dict[tuple[str, ...], EventKind]:
    """Each finite verb phrase, and its base form after "will"/"would" ("will hit")."""
    table: dict[tuple[str, ...], EventKind] = {verb: kind for verb in verbs}
    table.update({(modal, *verb): kind for verb in verbs for modal in FUTURE_MODALS})
    return table


SUBJECT_EVENT_PHRASES: Mapping[tuple[str, ...], EventKind] = {
    **_with_modals(_COLLISION_VERBS, "collision"),
    ("entrance",): "in",
    ("entering", "the", "scene"): "in",
    **_with_modals(_ENTER_VERBS, "in"),
    ("exit",): "out",
    ("exiting", "the", "scene"): "out",
    ("leaving", "the", "scene"): "out",
    **_with_modals(_EXIT_VERBS, "out"),
}

# Verb phrases closing a two-subject collision: "the cube and the sphere collide".
PAIR_COLLISION_PHRASES: frozenset[tuple[str, ...]] = frozenset({
    (*modal, *verb)
    for modal in ((), ("will",), ("would",))
    for verb in (("collide",), ("hit", "each", "other"), ("bump", "into", "each", "other"))
})

# How a question names the removal of an object, after "if <object>".
REMOVAL_PHRASES: frozenset[tuple[str, ...]] = frozenset({
    (aux, *verb) for aux in ("is", "were", "was") for verb in (("removed",), ("taken", "away"))
})
# "if we remove <object>", "if you remove <object>".
REMOVER_WORDS: tuple[str, ...] = ("we", "you")

# Openers of a wh-question: "which of the following", "which event", "what".
WH_PHRASES: frozenset[tuple[str, ...]] = frozenset(
    {("which", "of", "the", "following"), ("which", "event"), ("what",)}
)

QuestionType = Literal["explanatory", "predictive", "counterfactual"]
QUESTION_TYPES: tuple[str, ...] = ("explanatory", "predictive", "counterfactual")

# Program operators used by the compiler (names as in DESIGN.md).
OP_OBJECTS = "objects"
OP_EVENTS = "events"
OP_UNIQUE = "unique"
OP_NEGATE = "negate"
OP_BELONG_TO = "belong_to"
OP_FILTER_ANCESTOR = "filter_ancestor"
OP_UNSEEN_EVENTS = "unseen_events"
OP_ALL_EVENTS = "all_events"
OP_COUNTERFACT_EVENTS = "counterfact_events"
OP_FILTER_COUNTERFACT = "filter_counterfact"

# Operator spellings found in CLEVRER's released annotation files that name the
# same operation as DESIGN.md's executor name; used only to compare programs.
OFFICIAL_OPERATOR_ALIASES: Mapping[str, str] = {
    "get_counterfact": "filter_counterfact",
    "get_col_partner": "query_collision_partner",
    "get_frame": "query_frame",
    "get_object": "query_object",
}
