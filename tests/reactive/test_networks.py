"""The critic ensemble's two code paths (batched kernels for several members, addmm for one) are one
function: the same values and the same gradients."""
from __future__ import annotations

import torch

from cage_reactive_ddpg.networks import CriticEnsemble


def test_one_member_path_matches_the_batched_path():
    torch.manual_seed(0)
    twin = CriticEnsemble(12, (32, 16), 1, n=2)
    obs, act = torch.randn(7, 12), torch.randn(7, 1, requires_grad=True)
    both = twin(obs, act)
    first = twin(obs, act, members=1)
    assert both.shape == (2, 7) and first.shape == (1, 7)
    assert torch.allclose(both[0], first[0], atol=1e-6)
    assert not torch.allclose(both[0], both[1])                   # two members, two critics

    g_batched = torch.autograd.grad(both[0].sum(), [act, *twin.weights])
    g_one = torch.autograd.grad(first.sum(), [act, *twin.weights])
    for a, b in zip(g_batched, g_one):
        assert torch.allclose(a, b, atol=1e-6)


def test_frozen_reaches_the_action_but_not_the_weights():
    torch.manual_seed(1)
    single = CriticEnsemble(6, (8, 8), 1, n=1)
    act = torch.zeros(3, 1, requires_grad=True)
    q = single(torch.randn(3, 6), act, frozen=True)
    q.sum().backward()
    assert act.grad is not None and act.grad.abs().sum() > 0
    assert all(w.grad is None for w in single.weights)
