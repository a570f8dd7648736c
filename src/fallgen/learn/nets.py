"""Small fully convolutional networks in plain torch, sized for a CPU.

:class:`SegNet`: an encoder-decoder for semantic segmentation of a 300 x 300 RGB-D view. The
encoder halves the resolution four times (150, 75, 38, 19 pixels a side; strided 3 x 3
convolutions, then depthwise-separable blocks, dilated at the coarsest scale for context); the
decoder goes back up to 150 a side, adding at each scale the encoder's features of that scale
(a U-Net's skips). What keeps it fast on one core:

- every skip is joined by a sum, not a concatenation: a 1 x 1 convolution of the coarse
  features is computed at the coarse scale and then upsampled (a 1 x 1 convolution and a
  nearest-neighbour upsampling commute), the skip's own 1 x 1 convolution added;
- every batch normalisation directly follows a convolution, so :func:`fused` folds it into the
  convolution's weights for inference;
- features are kept channels-last (oneDNN's fast layout on x86), the class scores leave the
  network at 150 x 150 and the label map is doubled to 300 x 300 by repetition.

``SegNet.config`` (the widths, the classes, the input channels) is all that is needed to make
the network again around saved weights.
"""

from __future__ import annotations

import copy
from dataclasses import asdict, dataclass

from fallgen.learn import require_torch

torch = require_torch()  # ImportError saying how to install it, when it is not there
nn, F = torch.nn, torch.nn.functional


@dataclass(frozen=True)
class NetConfig:
    """The shape of a :class:`SegNet`: ``widths`` the channels at 1/2, 1/4, 1/8 and 1/16 of
    the input's side; ``classes`` the outputs; ``in_channels`` the input's (RGB + depth: 4)."""

    classes: int
    in_channels: int = 4
    widths: tuple[int, int, int, int] = (16, 32, 64, 128)

    def to_dict(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_dict(d: dict) -> NetConfig:
        return NetConfig(int(d["classes"]), int(d.get("in_channels", 4)),
                         tuple(int(w) for w in d["widths"]))


class ConvBN(nn.Module):
    """Convolution (no bias), batch normalisation, ReLU (unless ``act`` is False)."""

    def __init__(self, cin: int, cout: int, k: int = 3, stride: int = 1, dilation: int = 1,
                 groups: int = 1, act: bool = True) -> None:
        super().__init__()
        self.conv = nn.Conv2d(cin, cout, k, stride, padding=dilation * (k // 2),
                              dilation=dilation, groups=groups, bias=False)
        self.bn: nn.Module = nn.BatchNorm2d(cout)
        self.act = act

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = self.bn(self.conv(x))
        return F.relu(y, inplace=True) if self.act else y

    def fuse(self) -> None:
        """Fold the (eval-mode) batch normalisation into the convolution."""
        bn = self.bn
        if not isinstance(bn, nn.BatchNorm2d):
            return
        scale = bn.weight / torch.sqrt(bn.running_var + bn.eps)
        conv = self.conv
        fused = nn.Conv2d(conv.in_channels, conv.out_channels, conv.kernel_size, conv.stride,
                          conv.padding, conv.dilation, conv.groups, bias=True)
        with torch.no_grad():
            fused.weight.copy_(conv.weight * scale.reshape(-1, 1, 1, 1))
            fused.bias.copy_(bn.bias - bn.running_mean * scale)
        self.conv, self.bn = fused, nn.Identity()


class Separable(nn.Module):
    """A depthwise 3 x 3 convolution then a pointwise one, each with its normalisation and
    ReLU; a residual sum where the shapes agree."""

    def __init__(self, cin: int, cout: int, dilation: int = 1) -> None:
        super().__init__()
        self.dw = ConvBN(cin, cin, 3, dilation=dilation, groups=cin)
        self.pw = ConvBN(cin, cout, 1, act=False)
        self.residual = cin == cout

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = self.pw(self.dw(x))
        return F.relu(y + x if self.residual else y, inplace=True)


class Up(nn.Module):
    """The decoder's step: ``coarse`` features projected (1 x 1) at their own scale, upsampled
    to ``skip``'s size (nearest), the skip's projection added, ReLU, a separable block."""

    def __init__(self, c_coarse: int, c_skip: int, cout: int) -> None:
        super().__init__()
        self.coarse = ConvBN(c_coarse, cout, 1, act=False)
        self.skip = ConvBN(c_skip, cout, 1, act=False)
        self.block = Separable(cout, cout)

    def forward(self, coarse: torch.Tensor, skip: torch.Tensor) -> torch.Tensor:
        up = F.interpolate(self.coarse(coarse), size=skip.shape[-2:], mode="nearest")
        return self.block(F.relu(up + self.skip(skip), inplace=True))


class SegNet(nn.Module):
    """(N, in_channels, H, W) -> (N, classes, ceil(H / 2), ceil(W / 2)) class scores."""

    def __init__(self, config: NetConfig) -> None:
        super().__init__()
        self.config = config
        a, b, c, d = config.widths
        self.stem = ConvBN(config.in_channels, a, 3, stride=2)
        self.enc1 = nn.Sequential(ConvBN(a, b, 3, stride=2), Separable(b, b))
        self.enc2 = nn.Sequential(ConvBN(b, c, 3, stride=2), Separable(c, c))
        self.enc3 = nn.Sequential(ConvBN(c, d, 3, stride=2), Separable(d, d, 2),
                                  Separable(d, d, 4))
        self.up3 = Up(d, c, c)
        self.up2 = Up(c, b, b)
        self.up1 = Up(b, a, a)
        self.head = nn.Conv2d(a, config.classes, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x0 = self.stem(x)
        x1 = self.enc1(x0)
        x2 = self.enc2(x1)
        x3 = self.enc3(x2)
        y = self.up3(x3, x2)
        y = self.up2(y, x1)
        y = self.up1(y, x0)
        return self.head(y)


def fused(net: SegNet) -> SegNet:
    """A copy of ``net`` for inference: eval mode, batch normalisations folded into the
    convolutions, channels-last weights."""
    out = copy.deepcopy(net).eval()
    for m in out.modules():
        if isinstance(m, ConvBN):
            m.fuse()
    return out.to(memory_format=torch.channels_last)


def parameters(net: nn.Module) -> int:
    return sum(p.numel() for p in net.parameters())


__all__ = ["NetConfig", "SegNet", "ConvBN", "Separable", "Up", "fused", "parameters"]
