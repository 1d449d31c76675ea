"""Points on the unit sphere: ``near_any``, the revisit and re-plan thresholds' test."""

import numpy as np

from mjsuff.sphere import near_any, normalize


def test_near_any_is_the_largest_cosine_against_the_threshold():
    done = normalize(np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]))
    at_099 = np.array([0.99, np.sqrt(1 - 0.99**2), 0.0])  # cosine 0.99 to the first row
    assert near_any(done, at_099, 0.98)
    assert not near_any(done, at_099, 0.999)
    assert near_any(done, done[1], 1.0)  # itself, at the strictest threshold
    assert not near_any(done, np.array([0.0, 0.0, 1.0]), 0.5)  # orthogonal to both
    assert not near_any(done[:0], at_099, 0.1)  # nothing recorded yet
