"""Layer-normalised critics (``algo.critic_layer_norm``; relmogen-r, sac and oac; off by default).

Each Q network of the critic and of its target gets an ``nn.LayerNorm`` after every hidden
``nn.Linear``, before its activation; the last Linear (the Q value) gets none. This is the critic
of RLPD (Ball et al. 2023, "Efficient Online Reinforcement Learning with Offline Data"): layer
normalisation bounds a Q value by the norm of the last layer's weights, so a critic extrapolating
to actions the replay does not hold cannot run away, and in their runs it kept the Q values from
diverging where the critic without it did. Why here (issue 56): our SAC runs show a rising Q (in
the first PushDoorNav runs the critic's Q for the policy's own actions rose to about 3x the
observed returns, ``relmogen/agents/sac.py``'s module doc) before the policy collapsed.

Only the networks' modules change; the gradient step (``SharedEncoderSAC._gradient_step``) is
the same. ``SharedEncoderSACPolicy.make_critic`` applies it, so the critic and its target have
the same structure, and a saved model reloads it (the flag is one of the policy's keyword
arguments). Not yet measured on our tasks.
"""

from __future__ import annotations

from torch import nn


def with_layer_norm(q_net: nn.Sequential) -> nn.Sequential:
    """``q_net`` (SB3's ``create_mlp``: Linear, activation, ..., Linear) with an ``nn.LayerNorm``
    after each Linear but the last; the modules are ``q_net``'s own, not copies."""
    linears = [index for index, module in enumerate(q_net) if isinstance(module, nn.Linear)]
    if not linears:
        raise ValueError("a Q network without a Linear layer")
    modules: list[nn.Module] = []
    for index, module in enumerate(q_net):
        modules.append(module)
        if index in linears[:-1]:
            modules.append(nn.LayerNorm(module.out_features, device=module.weight.device,
                                        dtype=module.weight.dtype))
    return nn.Sequential(*modules)


def layer_normalise(critic) -> None:
    """Put ``with_layer_norm`` of each of an SB3 ``ContinuousCritic``'s Q networks in its place:
    in ``critic.q_networks`` and as the submodule ``qf<i>`` (the state_dict's names)."""
    for index, q_net in enumerate(critic.q_networks):
        critic.q_networks[index] = with_layer_norm(q_net)
        critic.add_module(f"qf{index}", critic.q_networks[index])
