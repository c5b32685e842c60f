"""A learning proof without a GPU or a deep-learning framework: the cross-entropy method
(CEM; Rubinstein 1999, as in Szita & Lőrincz 2006 for policy search) over a small linear
policy, in numpy.

The policy maps chosen observation entries, divided by their scales, through a linear
layer and a tanh onto the action box: ``action = mid + half * tanh(W f + b)``; all-zero
parameters give the middle of the box. CEM keeps a diagonal Gaussian over the parameters,
scores a population drawn from it, refits it to the best (elite) candidates and repeats.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from gymnasium import spaces


@dataclass(frozen=True)
class LinearPolicy:
    """``action = mid + half * tanh(W @ (obs[features] / scales) + b)`` on a Box."""

    action_space: spaces.Box
    features: tuple[int, ...]
    scales: tuple[float, ...]

    @property
    def size(self) -> int:
        """Number of parameters: W (actions x features) then b (actions)."""
        return self.action_space.shape[0] * (len(self.features) + 1)

    def act(self, params: np.ndarray, obs: np.ndarray) -> np.ndarray:
        n_act, n_in = self.action_space.shape[0], len(self.features)
        weights = params[:n_act * n_in].reshape(n_act, n_in)
        bias = params[n_act * n_in:]
        f = np.asarray(obs, dtype=np.float64)[list(self.features)] / np.asarray(self.scales)
        low, high = self.action_space.low, self.action_space.high
        return (0.5 * (low + high) + 0.5 * (high - low) * np.tanh(weights @ f + bias)
                ).astype(np.float32)


def rollout(env, act: Callable[[np.ndarray], np.ndarray], episode_seed: int
            ) -> tuple[float, float]:
    """One episode of ``env`` (reset with ``episode_seed``) flown by ``act``: its
    undiscounted return and its mean distance (m) from the trail point."""
    obs, _ = env.reset(options={"episode_seed": episode_seed})
    total, errors, done = 0.0, [], False
    while not done:
        obs, reward, terminated, truncated, info = env.step(act(obs))
        total += reward
        errors.append(info["position_error_m"])
        done = terminated or truncated
    return total, float(np.mean(errors))


@dataclass
class CemResult:
    """The final mean parameters and, per iteration, the mean score of the elite and of
    the mean parameters."""

    mean: np.ndarray
    elite_scores: list[float] = field(default_factory=list)
    mean_scores: list[float] = field(default_factory=list)


def cross_entropy_search(score: Callable[[np.ndarray], float], size: int,
                         rng: np.random.Generator, iterations: int = 6,
                         population: int = 12, elite: int = 3, init_std: float = 1.0,
                         min_std: float = 0.05) -> CemResult:
    """Maximise ``score(params)`` over ``size`` parameters from a zero mean."""
    mean, std = np.zeros(size), np.full(size, init_std)
    result = CemResult(mean)
    for _ in range(iterations):
        candidates = mean + std * rng.standard_normal((population, size))
        scores = np.array([score(c) for c in candidates])
        best = candidates[np.argsort(scores)[::-1][:elite]]
        mean, std = best.mean(axis=0), np.maximum(best.std(axis=0), min_std)
        result.elite_scores.append(float(np.sort(scores)[::-1][:elite].mean()))
        result.mean_scores.append(float(score(mean)))
    result.mean = mean
    return result


def mean_return(env, act: Callable[[np.ndarray], np.ndarray], seeds: Sequence[int]) -> float:
    """Mean return of :func:`rollout` over the episodes of ``seeds``."""
    return float(np.mean([rollout(env, act, s)[0] for s in seeds]))
