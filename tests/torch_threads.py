"""An autouse fixture that runs a test folder's torch work on one thread: with other
jobs on the 2 CI cores, two torch threads made the network tests about 10x slower.
A folder's ``conftest.py`` imports it (``from tests.torch_threads import one_torch_thread``)."""

import pytest
import torch


@pytest.fixture(autouse=True)
def one_torch_thread():
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)
