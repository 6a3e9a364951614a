import pytest

from bimanualshift.core.goal_nouns import extract_goal_nouns, singular, split_prompt


@pytest.mark.parametrize(("instruction", "nouns"), [
    ("push the red and the blue buttons", ["red button", "blue button"]),
    ("Push the maroon and the olive buttons.", ["maroon button", "olive button"]),
    ("push the olive and the violet buttons, then lift the ball", ["olive button", "violet button", "ball"]),
    ("push the button", ["button"]),
    ("pick up the small black cube", ["black cube"]),
    ("take the tray out of the oven", ["tray"]),
    ("take tray out of oven", ["tray"]),
    ("open the oven and take out the tray", ["oven", "tray"]),
    ("pick up the plate", ["plate"]),
    ("lift the ball", ["ball"]),
    ("pull the rope straight", ["rope"]),
    ("pull both ends of the rope apart", ["rope"]),
    ("lay the rope out straight", ["rope"]),
    ("stretch the rope between the two targets", ["rope"]),
    ("sweep the dirt to the dustpan", ["dirt"]),
    ("brush the dirt into the dustpan", ["dirt"]),
    ("open the oven door", ["oven"]),
    ("slide the gold block onto the target", ["gold block"]),
    ("pick up the cup and the spoon", ["cup", "spoon"]),
    ("stack the boxes", ["box"]),
    ("put the knives in the drawer", ["knife"]),
])
def test_rules_find_the_direct_object(instruction: str, nouns: list[str]) -> None:
    assert extract_goal_nouns(instruction) == nouns


def test_singular_keeps_uncountable_and_short_words() -> None:
    assert [singular(w) for w in ("buttons", "brushes", "berries", "dirt", "glass", "bus")] == \
        ["button", "brush", "berry", "dirt", "glass", "bus"]


def test_no_noun_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="no goal noun found"):
        extract_goal_nouns("push the red")
    with pytest.raises(ValueError, match="no words"):
        extract_goal_nouns("!!")


def test_split_prompt_separates_a_colour_attribute() -> None:
    assert split_prompt("navy button") == ("navy", "button")
    assert split_prompt("button") == (None, "button")
    assert split_prompt("robotic arm") == (None, "robotic arm")


@pytest.mark.parametrize(("instruction", "nouns"), [
    ("toast the bread and serve it on the plate", ["bread"]),  # a pronoun names no new goal
    ("press the toaster's lever down", ["toaster"]),  # a possessive's part names its whole
    ("hold the toaster and press its lever down", ["toaster"]),  # "its lever": the toaster, named before
    ("hold the toaster steady by its handle", ["toaster"]),  # "steady" is a complement, not a noun
    ("hold the toaster and put the bread in its slot", ["toaster", "bread"]),
])
def test_pronouns_possessives_and_complements(instruction: str, nouns: list[str]) -> None:
    assert extract_goal_nouns(instruction) == nouns
