"""SyncNet (Chung & Zisserman 2016), the public "syncnet_v2" architecture.

Module names (``netcnnaud``, ``netfcaud``, ``netcnnlip``, ``netfclip``) and layer
order follow the public weights file so that it loads strictly. Inputs: 5 video
frames of a 224 x 224 BGR face crop in [0, 255] at 25 fps, and the 13 x 20 MFCC
block of the same 0.2 s.
"""

from __future__ import annotations

from collections.abc import Mapping
from os import PathLike

import torch
from torch import nn

from blendvoca.assets import resolve
from blendvoca.errors import DataError
from blendvoca.io.torch_file import read_torch_file


def _conv2d_bn(cin, cout, k, pad, pool=None):
    layers = [nn.Conv2d(cin, cout, kernel_size=k, stride=1, padding=pad), nn.BatchNorm2d(cout), nn.ReLU()]
    if pool is not None:
        layers.append(nn.MaxPool2d(kernel_size=pool[0], stride=pool[1]))
    return layers


def _conv3d_bn(cin, cout, k, stride=1, pad=0, pool=None):
    layers = [nn.Conv3d(cin, cout, kernel_size=k, stride=stride, padding=pad), nn.BatchNorm3d(cout), nn.ReLU()]
    if pool is not None:
        layers.append(nn.MaxPool3d(kernel_size=pool[0], stride=pool[1], padding=pool[2]))
    return layers


def _head(embedding: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(512, 512), nn.BatchNorm1d(512), nn.ReLU(), nn.Linear(512, embedding))


class SyncNet(nn.Module):
    """Audio and lip-video embedding networks of SyncNet.

    Parameters
    ----------
    embedding : int
        Output dimension of both streams (1024 in the public weights).
    """

    def __init__(self, embedding: int = 1024):
        super().__init__()
        self.netcnnaud = nn.Sequential(
            *_conv2d_bn(1, 64, 3, 1, pool=((1, 1), (1, 1))),
            *_conv2d_bn(64, 192, 3, 1, pool=((3, 3), (1, 2))),
            *_conv2d_bn(192, 384, 3, 1),
            *_conv2d_bn(384, 256, 3, 1),
            *_conv2d_bn(256, 256, 3, 1, pool=((3, 3), (2, 2))),
            *_conv2d_bn(256, 512, (5, 4), 0),
        )
        self.netfcaud = _head(embedding)
        self.netfclip = _head(embedding)
        self.netcnnlip = nn.Sequential(
            *_conv3d_bn(3, 96, (5, 7, 7), stride=(1, 2, 2), pool=((1, 3, 3), (1, 2, 2), 0)),
            *_conv3d_bn(96, 256, (1, 5, 5), stride=(1, 2, 2), pad=(0, 1, 1), pool=((1, 3, 3), (1, 2, 2), (0, 1, 1))),
            *_conv3d_bn(256, 256, (1, 3, 3), pad=(0, 1, 1)),
            *_conv3d_bn(256, 256, (1, 3, 3), pad=(0, 1, 1)),
            *_conv3d_bn(256, 256, (1, 3, 3), pad=(0, 1, 1), pool=((1, 3, 3), (1, 2, 2), 0)),
            *_conv3d_bn(256, 512, (1, 6, 6)),
        )

    def forward_aud(self, mfcc_blocks: torch.Tensor) -> torch.Tensor:
        """(B, 1, 13, 20) MFCC blocks -> (B, embedding)."""
        return self.netfcaud(self.netcnnaud(mfcc_blocks).flatten(1))

    def forward_lip(self, clips: torch.Tensor) -> torch.Tensor:
        """(B, 3, 5, 224, 224) BGR clips in [0, 255] -> (B, embedding)."""
        return self.netfclip(self.netcnnlip(clips).flatten(1))


class SyncNetWeightsError(DataError, RuntimeError):
    """A weights file that is not SyncNet's state_dict: unreadable, not a mapping, or with
    keys or shapes that do not fit (a :class:`~blendvoca.errors.DataError`, exit 2 on the
    command line; also a ``RuntimeError``, as ``load_state_dict``'s own error)."""


def load_syncnet(path: str | PathLike | None = None) -> SyncNet:
    """SyncNet in eval mode with weights from ``path`` (default: the manifest asset
    ``syncnet-weights``, which must be placed by hand; see data_manifest.yaml).

    The file is a state_dict (``syncnet_v2.model``); it must match strictly.

    Raises
    ------
    UserError
        No file at ``path``.
    SyncNetWeightsError
        The file is not a SyncNet state_dict (naming the file, and torch's list of keys).
    """
    if path is None:
        path = resolve("syncnet-weights")
    state = read_torch_file(path, where="load_syncnet", error=SyncNetWeightsError)
    if not isinstance(state, Mapping):
        raise SyncNetWeightsError(f"load_syncnet: {path} holds a {type(state).__name__}, expected a state_dict")
    embedding = int(state["netfcaud.3.weight"].shape[0]) if "netfcaud.3.weight" in state else 1024
    model = SyncNet(embedding)
    try:
        model.load_state_dict(state, strict=True)
    except RuntimeError as error:  # torch's message lists the missing, unexpected and mismatched keys
        raise SyncNetWeightsError(f"load_syncnet: {path}: {error}") from None
    return model.eval()
