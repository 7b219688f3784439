"""Lip-sync measures: SyncNet AV offset/confidence and a weight-free geometric one."""

from benchmark.lipsync.envelope import speech_envelope
from benchmark.lipsync.geometric import (
    SyncEstimate,
    geometric_sync,
    lagged_correlation,
    mouth_activity,
    offset_from_scores,
)
from benchmark.lipsync.mfcc import mfcc
from benchmark.lipsync.syncnet import SyncNet, load_syncnet
from benchmark.lipsync.syncnet_eval import syncnet_inputs, syncnet_sync, syncnet_sync_track, syncnet_sync_video

__all__ = ["SyncEstimate", "SyncNet", "geometric_sync", "lagged_correlation", "load_syncnet", "mfcc",
           "mouth_activity", "offset_from_scores", "speech_envelope", "syncnet_inputs", "syncnet_sync",
           "syncnet_sync_track", "syncnet_sync_video"]
