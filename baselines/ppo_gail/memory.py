"""The memory of a recurrent actor (rsl-rl's ``RNNModel``: normaliser, RNN, MLP head) in a policy file: the
``memory`` entry of the ``cabinbench-policy/1`` format (``baselines.ppo_gail.policy``), whose ``actor`` is
then the MLP head on the RNN's output, and the RNN that ``networks.Inference`` runs it with (``rnn``)."""

from __future__ import annotations

import torch
import torch.nn as nn
import torch.nn.functional as F

RNN_TYPES = {"lstm": nn.LSTM, "gru": nn.GRU}


def memory_entry(model, normalizer: dict | None) -> dict:
    """The ``memory`` entry of a policy file of rsl-rl's recurrent ``model``, whose observation ``normalizer``
    (or None) feeds its RNN."""
    rnn = model.rnn.rnn
    return {
        "rnn_type": "lstm" if isinstance(rnn, nn.LSTM) else "gru",
        "input_size": int(model.obs_dim),
        "hidden_size": int(rnn.hidden_size),
        "num_layers": int(rnn.num_layers),
        "state_dict": {key: value.detach().cpu().clone() for key, value in rnn.state_dict().items()},
        "obs_normalizer": normalizer,
    }


def rnn(entry: dict, dtype: torch.dtype) -> nn.Module:
    """The RNN of a ``memory`` entry in ``dtype``: torch's ``nn.LSTM`` or ``nn.GRU`` in float32, as trained;
    its ``WrittenOutRNN`` in float64."""
    sizes = (entry["input_size"], entry["hidden_size"], entry["num_layers"])
    network = (
        RNN_TYPES[entry["rnn_type"]](*sizes)
        if dtype == torch.float32
        else WrittenOutRNN(entry["rnn_type"], *sizes)
    )
    network.load_state_dict(entry["state_dict"], strict=True)
    return network.to(dtype).eval()


class WrittenOutRNN(nn.Module):
    """``nn.LSTM`` or ``nn.GRU`` (their weights under their names, their gates in their order) written out as
    matrix products and gates. onnxruntime runs no float64 LSTM or GRU, so a float64 policy's ONNX twin
    computes these expressions, and its torch side computes the same ones. Called as torch's are:
    ``(input [T, B, D], state) -> (output [T, B, H], state)``, the state ``(hidden, cell)`` [L, B, H] of an
    LSTM, ``hidden`` of a GRU, never None."""

    def __init__(self, rnn_type: str, input_size: int, hidden_size: int, num_layers: int) -> None:
        super().__init__()
        self.lstm = rnn_type == "lstm"
        gates = (4 if self.lstm else 3) * hidden_size
        for layer in range(num_layers):
            width = input_size if layer == 0 else hidden_size
            for name, shape in (("weight_ih", (gates, width)), ("weight_hh", (gates, hidden_size))):
                self.register_parameter(f"{name}_l{layer}", nn.Parameter(torch.empty(shape)))
            for name in ("bias_ih", "bias_hh"):
                self.register_parameter(f"{name}_l{layer}", nn.Parameter(torch.empty(gates)))
        self.num_layers = num_layers

    def forward(self, sequence: torch.Tensor, state):
        hidden, cell = (list(state[0]), list(state[1])) if self.lstm else (list(state), None)  # by layer
        outputs = []
        for values in sequence:
            for layer in range(self.num_layers):
                from_input = F.linear(values, *self.weights(layer, "ih"))
                from_hidden = F.linear(hidden[layer], *self.weights(layer, "hh"))
                if self.lstm:  # torch's LSTMCell
                    in_gate, forget_gate, cell_gate, out_gate = (from_input + from_hidden).chunk(4, dim=-1)
                    cell[layer] = forget_gate.sigmoid() * cell[layer] + in_gate.sigmoid() * cell_gate.tanh()
                    values = out_gate.sigmoid() * cell[layer].tanh()
                else:  # torch's GRUCell
                    reset_i, update_i, new_i = from_input.chunk(3, dim=-1)
                    reset_h, update_h, new_h = from_hidden.chunk(3, dim=-1)
                    new_gate = (new_i + (reset_i + reset_h).sigmoid() * new_h).tanh()
                    values = new_gate + (update_i + update_h).sigmoid() * (hidden[layer] - new_gate)
                hidden[layer] = values
            outputs.append(values)
        hidden = torch.stack(hidden)
        return torch.stack(outputs), ((hidden, torch.stack(cell)) if self.lstm else hidden)

    def weights(self, layer: int, source: str) -> tuple[torch.Tensor, torch.Tensor]:
        return getattr(self, f"weight_{source}_l{layer}"), getattr(self, f"bias_{source}_l{layer}")
