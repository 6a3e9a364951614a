"""Goal nouns from an instruction: what the segmenter is prompted with next to "robotic arm".

The rule set, in order:

1. Lower-case, drop possessive 's ("the toaster's lever" -> "the toaster lever") and punctuation, split into
   words.
2. The instruction is split into clauses where "and" / "then" is followed by a verb ("open the oven and take
   out the tray" -> two clauses); every clause contributes.
3. A clause's direct object is the words after its leading verb (and the verb's particle: "pick *up*",
   "take *out*") up to the first preposition, particle or complement that starts a place, an instrument or a
   result ("out of", "into", "to", "onto", "from", "with", "between", "straight", ...).
   "take the tray out of the oven" -> "the tray".
4. The object is split into coordinated parts at "and" / "or"; in each part determiners, sizes and other
   known modifiers are dropped and the last remaining word is the head noun. A colour word is kept as the
   part's attribute and prefixed to its noun ("the blue button" -> "blue button"), the way a referring
   expression is given to an open-vocabulary detector: when several objects share the noun (three buttons,
   two of them named), only the named ones are goals. A part with a colour but no noun of its own shares
   the next part's noun ("the blue and the navy buttons" -> "blue button", "navy button").
5. A part noun names its whole: "both ends *of the rope*" -> rope, "the oven door" -> oven.
6. A pronoun ("serve *it*") refers to a goal already named and adds none; so does a part noun after a
   possessive pronoun ("press *its lever*": the whole named before).
7. Head nouns are singularised ("buttons" -> "button", "brushes" -> "brush"; uncountable words stay) and
   de-duplicated in order.

When a task knows better (the goal of "open the oven door" is the oven, a tray task also needs the oven to
be seen), its ``Task.goal_nouns`` overrides the rules; a user with a real robot passes ``--goal-nouns``.
"""

from __future__ import annotations

import re

from bimanualshift.core.colours import TRAIN_COLOURS, UNSEEN_COLOURS

DETERMINERS = {"the", "a", "an", "both", "all", "each", "every", "two", "three", "four", "five", "some", "its",
               "their", "that", "this", "these", "those", "other"}
MODIFIERS = {"small", "big", "large", "little", "tiny", "left", "right", "top", "bottom", "front", "back",
             "red-ish", "named", "first", "second", "last", "near", "far", *TRAIN_COLOURS, *UNSEEN_COLOURS}
PARTICLES = {"up", "out", "down", "off", "over", "away", "back", "open", "apart"}
PREPOSITIONS = {"of", "into", "to", "onto", "from", "in", "on", "with", "towards", "toward", "between", "at",
                "inside", "under", "above", "below", "beside", "next", "using", "by", "until", "so"}
COORDINATORS = {"and", "or", "then"}
COLOURS = {*TRAIN_COLOURS, *UNSEEN_COLOURS}
COMPLEMENTS = {"straight", "flat", "level", "tight", "closed", "shut", "upright", "together", "steady", "still"}
PRONOUNS = {"it", "them", "itself", "themselves", "one", "ones"}
POSSESSIVE_PRONOUNS = {"its", "their"}
VERBS = {"push", "press", "lift", "pick", "take", "put", "place", "open", "close", "sweep", "slide", "pull",
         "straighten", "grasp", "grab", "hold", "drag", "remove", "get", "move", "stack", "brush", "lay", "stretch",
         "turn", "rotate", "insert", "hand", "give", "wipe", "fold", "pour", "carry", "raise", "set", "drop", "serve",
         "route", "thread", "steady", "arrange"}
PART_NOUNS = {"end", "ends", "side", "sides", "edge", "edges", "handle", "handles", "door", "lid", "top", "corner",
              "rim", "tab", "knob", "lever", "slot"}
UNCOUNTABLE = {"dirt", "rope", "dust", "water", "sand", "cloth", "glass", "paper"}
IRREGULAR = {"knives": "knife", "leaves": "leaf", "shelves": "shelf", "people": "person", "feet": "foot"}


def singular(word: str) -> str:
    if word in IRREGULAR:
        return IRREGULAR[word]
    if word in UNCOUNTABLE or len(word) <= 3 or word.endswith("ss"):
        return word
    if word.endswith("ies"):
        return word[:-3] + "y"
    if word.endswith(("ches", "shes", "xes", "sses", "zes")):
        return word[:-2]
    if word.endswith("s"):
        return word[:-1]
    return word


def extract_goal_nouns(instruction: str) -> list[str]:
    """The head nouns of the instruction's direct objects (see the module docstring for the rules)."""
    words = re.findall(r"[a-z][a-z\-]*", re.sub(r"'s\b", "", instruction.lower()))
    if not words:
        raise ValueError(f"instruction {instruction!r} has no words to take a goal noun from")
    clauses: list[list[str]] = [[]]
    for i, word in enumerate(words):
        if word in COORDINATORS and i + 1 < len(words) and words[i + 1] in VERBS and clauses[-1]:
            clauses.append([])
        else:
            clauses[-1].append(word)
    nouns: list[str] = []
    for clause in clauses:
        for noun in _object_nouns(clause):
            if noun not in nouns:
                nouns.append(noun)
    if not nouns:
        raise ValueError(f"no goal noun found in {instruction!r}; give the task's goal nouns explicitly "
                         "(Task.goal_nouns, or --goal-nouns on the command line)")
    return nouns


def _object_nouns(clause: list[str]) -> list[str]:
    i = 1  # the leading word is the verb ("push", "lift", "sweep", ...)
    while i < len(clause) and clause[i] in PARTICLES:
        i += 1
    obj: list[str] = []
    rest = clause[i:]
    for j, word in enumerate(rest):
        if word == "of" and obj and obj[-1] in PART_NOUNS:  # "both ends of the rope": the whole is the goal
            return _object_nouns(["_", *rest[j + 1 :]])
        if word in PREPOSITIONS or word in COMPLEMENTS or (word in PARTICLES and obj):
            break
        obj.append(word)
    parts: list[tuple[str | None, str | None]] = []  # (colour, head noun) per coordinated part
    part: list[str] = []
    for word in [*obj, "and"]:
        if word in COORDINATORS:
            colours = [w for w in part if w in COLOURS]
            content = [w for w in part if w not in DETERMINERS and w not in MODIFIERS and w not in PRONOUNS]
            if len(content) == 1 and content[0] in PART_NOUNS and POSSESSIVE_PRONOUNS & set(part):
                content = []  # "its lever": a part of a goal already named
            if len(content) >= 2 and content[-1] in PART_NOUNS:  # "the oven door": the whole is the goal
                content = content[:-1]
            if content or colours:
                parts.append((colours[-1] if colours else None, singular(content[-1]) if content else None))
            part = []
        else:
            part.append(word)
    nouns = []
    for i, (colour, noun) in enumerate(parts):
        # "the blue and the navy buttons": a colour without a noun takes the next part's noun
        noun = noun or next((n for _, n in parts[i + 1:] if n), None)
        if noun:
            nouns.append(f"{colour} {noun}" if colour else noun)
    return nouns


def split_prompt(prompt: str) -> tuple[str | None, str]:
    """A goal prompt as (colour attribute or None, noun): "navy button" -> ("navy", "button")."""
    words = prompt.split()
    if len(words) >= 2 and words[0] in COLOURS:
        return words[0], " ".join(words[1:])
    return None, prompt
