"""Lip-sync measures: SyncNet AV offset/confidence, a learned sync expert on coefficient
tracks (:func:`load_expert`) and a weight-free geometric one."""

from benchmark.lipsync.envelope import speech_envelope
from benchmark.lipsync.expert import SyncExpert, load_expert, save_expert
from benchmark.lipsync.expert_metrics import expert_sync_metrics
from benchmark.lipsync.expert_training import cached_expert, train_expert
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

__all__ = ["SyncEstimate", "SyncExpert", "SyncNet", "cached_expert", "expert_sync_metrics", "geometric_sync", "lagged_correlation",
           "load_expert", "load_syncnet", "mfcc", "mouth_activity", "offset_from_scores", "save_expert",
           "speech_envelope", "syncnet_inputs", "syncnet_sync", "syncnet_sync_track", "syncnet_sync_video", "train_expert"]
