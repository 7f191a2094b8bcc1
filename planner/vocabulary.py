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

# Surface word -> (attribute kind, canonical value). Only spellings that
# CLEVRER-style text uses (plus the British "grey"); no guessing of synonyms.
ATTRIBUTE_WORDS: Mapping[str, tuple[AttributeKind, str]] = {
    **{color: ("color", color) for color in COLORS},
    "grey": ("color", "gray"),
    **{material: ("material", material) for material in MATERIALS},
    **{shape: ("shape", shape) for shape in SHAPES},
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
SUBJECT_EVENT_PHRASES: Mapping[tuple[str, ...], EventKind] = {
    ("colliding", "with"): "collision",
    ("collides", "with"): "collision",
    ("will", "collide", "with"): "collision",
    ("entrance",): "in",
    ("entering", "the", "scene"): "in",
    ("enters", "the", "scene"): "in",
    ("will", "enter", "the", "scene"): "in",
    ("exit",): "out",
    ("exiting", "the", "scene"): "out",
    ("exits", "the", "scene"): "out",
    ("will", "exit", "the", "scene"): "out",
}

# Verb phrases closing a two-subject collision: "the cube and the sphere collide".
PAIR_COLLISION_PHRASES: frozenset[tuple[str, ...]] = frozenset({("collide",), ("will", "collide")})

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
