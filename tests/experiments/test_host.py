from relmogen.experiments.host import cpu_model_and_flags, host_info, host_kind

CPUINFO = """processor\t: 0
model name\t: Intel(R) Xeon(R) Platinum 8488C
flags\t\t: fpu sse2 avx2 avx512f avx512_bf16 amx_tile amx_bf16
processor\t: 1
model name\t: Intel(R) Xeon(R) Platinum 8488C
flags\t\t: fpu
"""


def test_the_first_processors_model_and_flags_are_read():
    model, flags = cpu_model_and_flags(CPUINFO)
    assert model == "Intel(R) Xeon(R) Platinum 8488C"
    assert {"avx2", "avx512f", "amx_tile"} <= flags


def test_host_kinds_follow_the_instruction_sets():
    assert host_kind({"avx2", "avx512f", "amx_tile"}) == "avx512-amx"
    assert host_kind({"avx2", "avx512f"}) == "avx512"
    assert host_kind({"avx2"}) == "avx2"
    assert host_kind(set()) == "other"


def test_host_info_names_this_machine():
    info = host_info()
    assert info["cpu_model"] and info["cpus"] >= 1 and info["torch"].startswith("2.")
    assert info["host_kind"] == host_kind({flag for flag, present in info["isa"].items() if present})
