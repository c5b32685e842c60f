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
        return self.act_many(np.asarray(params)[None, :], np.asarray(obs)[None, :])[0]

    def act_many(self, params: np.ndarray, obs: np.ndarray) -> np.ndarray:
        """Actions (N, actions) of N parameter rows (N, size) on N observations."""
        n_act, n_in = self.action_space.shape[0], len(self.features)
        weights = params[:, :n_act * n_in].reshape(-1, n_act, n_in)
        bias = params[:, n_act * n_in:]
        f = np.asarray(obs, dtype=np.float64)[:, list(self.features)] / np.asarray(self.scales)
        low, high = self.action_space.low, self.action_space.high
        u = np.einsum("nij,nj->ni", weights, f) + bias
        return (0.5 * (low + high) + 0.5 * (high - low) * np.tanh(u)).astype(np.float32)


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
    the mean parameters (after the iteration; :func:`cross_entropy_search_vector`: the
    mean it started from, scored with its population), and (vector search) the env
    steps taken so far."""

    mean: np.ndarray
    elite_scores: list[float] = field(default_factory=list)
    mean_scores: list[float] = field(default_factory=list)
    env_steps: list[int] = field(default_factory=list)


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


def vector_returns(vec, policy: LinearPolicy, params: np.ndarray,
                   episode_seeds: Sequence[int]) -> tuple[np.ndarray, int]:
    """Mean return of each parameter row of ``params`` (C, size) over the episodes of
    ``episode_seeds`` (E), all C x E episodes flown at once in ``vec``, a native vector env
    of C x E sub-environments (:class:`~uhrisim.envs.vector.TrailDiverVectorEnv`); and the
    env steps it took. Each sub-environment counts its first episode only."""
    c, e = len(params), len(episode_seeds)
    rows = np.repeat(params, e, axis=0)
    obs, _ = vec.reset(options={"episode_seeds": [int(s) for s in episode_seeds] * c})
    total, done, steps = np.zeros(c * e), np.zeros(c * e, bool), 0
    while not done.all():
        obs, reward, terminated, truncated, _ = vec.step(policy.act_many(rows, obs))
        total += np.where(done, 0.0, reward)
        steps += int(np.count_nonzero(~done))
        done |= terminated | truncated
    return total.reshape(c, e).mean(axis=1), steps


def cross_entropy_search_vector(vec, policy: LinearPolicy, episode_seeds: Sequence[int],
                                rng: np.random.Generator, iterations: int, population: int,
                                elite: int, init_std: float = 1.0,
                                min_std: float = 0.05) -> CemResult:
    """:func:`cross_entropy_search` with every iteration's population and its mean scored
    in one native vector env of (population + 1) x len(episode_seeds) sub-environments;
    ``CemResult.env_steps`` holds the env steps taken up to each iteration."""
    mean, std = np.zeros(policy.size), np.full(policy.size, init_std)
    result, steps = CemResult(mean), 0
    for _ in range(iterations):
        candidates = mean + std * rng.standard_normal((population, policy.size))
        scores, taken = vector_returns(vec, policy, np.vstack([mean, candidates]),
                                       episode_seeds)
        steps += taken
        order = np.argsort(scores[1:])[::-1][:elite]
        result.mean_scores.append(float(scores[0]))
        result.elite_scores.append(float(scores[1:][order].mean()))
        result.env_steps.append(steps)
        best = candidates[order]
        mean, std = best.mean(axis=0), np.maximum(best.std(axis=0), min_std)
    result.mean = mean
    return result
