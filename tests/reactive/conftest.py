"""Shared fixtures for the reactive-layer tests: one thread, tiny configs, temp dirs."""
import pytest
import torch

torch.set_num_threads(1)


@pytest.fixture
def tiny_overrides():
    """A DDPG small enough to train in seconds (the study's algorithm, shrunk)."""
    return {"actor_hidden": [32, 32], "critic_hidden": [32, 32], "batch_size": 32, "buffer_size": 5000,
            "tensorboard": False, "eval_episodes": 20, "threads": 1}
