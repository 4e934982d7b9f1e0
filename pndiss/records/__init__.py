"""Encoder records: I&M, PROFIdrive parameter access, user parameters, profile selection.

``decode_record(index, data, write=..., profile=...)`` dispatches on the record index (table
``DECODERS``) and returns a dict with at least ``index_name``; bad bytes raise Malformed.
"""
from __future__ import annotations

from ..proto.common import Malformed
from . import im, profidrive, userparams
from .im import IM_PROFILE_IDS, VENDORS
from .names import index_name
from .profidrive import ParamPairer, param_info
from .profiles import select_profile

__all__ = ["decode_record", "index_name", "ParamPairer", "select_profile", "param_info", "im",
           "IM_PROFILE_IDS", "VENDORS", "Malformed"]


def _im(index, data, write, profile):
    return im.decode_im(index, data)


def _param_access(index, data, write, profile):
    # the controller writes the request and reads the response back (001_9461bb7bc8c2767b.txt:2093, 2101)
    if write:
        return profidrive.decode_request(data, profile)
    return profidrive.decode_response(data, profile)


def _user_params(index, data, write, profile):
    return userparams.decode_bf00(data, profile)


def _psm_ffff(index, data, write, profile):
    # PS/PSM keeps its user parameters at 0xFFFF (002_d69f444daf0f8af2.txt:982-1020)
    return userparams.decode_bf00(data, "psm") if profile == "psm" else None


def _vendor_1000(index, data, write, profile):
    return userparams.decode_vendor_1000(data, profile) if profile in ("scancon", "hohner", "psm") else None


def _param_control(index, data, write, profile):
    return userparams.decode_param_control(data) if profile == "psm" else None


DECODERS = {0xAFF0: _im, 0xAFF1: _im, 0xAFF2: _im, 0xAFF3: _im, 0xAFF4: _im,
            0xB02E: _param_access, 0xB02F: _param_access,
            0xBF00: _user_params, 0xFFFF: _psm_ffff, 0x1000: _vendor_1000, 0x1001: _param_control}


def decode_record(index: int, data: bytes, *, write: bool, profile: str = "generic") -> dict:
    """Decode record ``index`` (write request data if ``write``, else read response data)."""
    fn = DECODERS.get(index)
    dec = fn(index, data, write, profile) if fn else None
    out = {"index": index, "index_name": index_name(index)}
    if dec is None:
        out["data"] = data.hex()  # not decoded: keep the bytes
        return out
    out.update(dec)
    return out
