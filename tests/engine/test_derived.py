"""The one store of derived forms (engine/derived.py): made once per key, the least
recently used dropped beyond the bound, one object when threads race, and a network's
or expression's forms kept on it."""

from __future__ import annotations

import copy as copy_module
import dataclasses
import pickle
import threading

from engine.analysis import unity_feedback
from engine.derived import Derived, Form
from engine.loop.design import closed_loop_realization, design
from engine.model.expressions import Expression

SQUARE: Form[int] = Form("square")
LABEL: Form[str] = Form("label")


def test_a_form_is_made_once_per_key_and_forms_of_one_name_are_apart():
    store, made = Derived(), []

    def square(x: int):
        def make() -> int:
            made.append(x)
            return x * x

        return make

    assert store.get(SQUARE, square(3), 3) == 9
    assert store.get(SQUARE, square(3), 3) == 9 and made == [3]
    assert store.get(SQUARE, square(4), 4) == 16 and made == [3, 4]
    other: Form[int] = Form("square")  # the same name, another form: keys by identity
    assert store.get(other, lambda: -1, 3) == -1
    assert store.get(LABEL, lambda: None, 3) is None and store.get(LABEL, lambda: "made again", 3) is None


def test_the_least_recently_used_form_is_dropped_beyond_the_bound():
    store = Derived(most=3)
    for x in (1, 2, 3):
        store.get(SQUARE, lambda x=x: x * x, x)
    store.get(SQUARE, lambda: 0, 1)  # 1 used again: 2 is now the least recently used
    store.get(SQUARE, lambda: 16, 4)
    assert [key[1] for key in store._kept] == [3, 1, 4]
    assert store.get(SQUARE, lambda: -4, 2) == -4  # made again


def test_threads_that_make_one_form_at_once_share_the_first_made():
    store, started = Derived(), threading.Barrier(4)
    found: list[object] = []

    def make() -> object:
        return object()

    def ask() -> None:
        started.wait()
        found.append(store.get(LABEL, make, "x"))

    threads = [threading.Thread(target=ask) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(found) == 4 and all(f is found[0] for f in found)


def test_a_store_pickled_or_copied_arrives_empty():
    e = Expression("K/(s + a)")
    e.rational({"K": 2.0, "a": 1.0})
    for copy in (pickle.loads(pickle.dumps(e)), copy_module.deepcopy(e)):
        assert copy.derived._kept == {} and copy.derived.most == e.derived.most
        assert copy.rational({"K": 2.0, "a": 1.0}).num.tolist() == e.rational({"K": 2.0, "a": 1.0}).num.tolist()


def test_an_expression_keeps_its_forms_per_parameter_values():
    e = Expression("K/(s + a)")
    first = e.rational({"K": 2.0, "a": 1.0})
    assert e.rational({"a": 1.0, "K": 2.0}) is first
    assert e.rational({"K": 3.0, "a": 1.0}) is not first


def test_a_network_keeps_its_designs_and_a_copy_starts_its_own_store():
    network = unity_feedback(["K/(s*(s + 1))"])
    params = {"K": 2.0}
    kept = design(network, params)
    assert design(network, {"K": 3.0}) is not kept and design(network, params) is kept  # the last few are kept
    copy = dataclasses.replace(network, sample_time=0.1)
    assert copy.derived is not network.derived
    realization = kept.loop("e").realization
    closed = closed_loop_realization(network, "e", params)  # from the one kept realization
    assert kept.loop("e").realization is realization and closed.A.shape == realization.A.shape


def test_a_table_block_pickled_or_copied_remembers_nothing_and_answers_the_same():
    """A table block's remembered grids are a store like the others: a copy (a session's
    problem deep-copied, a network pickled) arrives empty and answers as the original (a bare
    lock in the block made both raise 'cannot pickle _thread.lock')."""
    import numpy as np

    from engine.model.blocks import FrequencyTable, TabulatedTransfer

    w = np.logspace(-1, 2, 30)
    block = TabulatedTransfer(FrequencyTable(w, 1 / (1j * w + 1)))
    grid = np.logspace(-1, 2, 7)
    block.response(grid)
    for copy in (pickle.loads(pickle.dumps(block)), copy_module.deepcopy(block)):
        assert np.array_equal(copy.response(grid), block.response(grid))
