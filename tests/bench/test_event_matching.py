"""bench.metrics.unmatched_events / match_events: greedy one-to-one matching of (pair, frame) events."""

from bench.metrics import match_events, unmatched_events


def test_each_event_is_matched_once_to_the_nearest_of_its_pair_within_tolerance():
    world = [((0, 1), 10), ((0, 1), 12), ((1, 2), 40), ((0, 2), 90)]
    truth = [((0, 1), 11), ((1, 2), 52), ((0, 2), 88)]
    # (0, 1) at 12 finds 11 taken by 10; (1, 2) is 12 frames off; (0, 2) is 2 frames off
    assert unmatched_events(world, truth, tolerance=5) == [((0, 1), 12), ((1, 2), 40)]
    assert unmatched_events(truth, world, tolerance=5) == [((1, 2), 52)]
    score = match_events(world, truth, tolerance=5)
    assert (score.true_positives, score.predicted, score.actual) == (2, 4, 3)


def test_another_pair_at_the_same_frame_is_no_match():
    assert unmatched_events([((0, 1), 20)], [((0, 2), 20)], tolerance=5) == [((0, 1), 20)]
