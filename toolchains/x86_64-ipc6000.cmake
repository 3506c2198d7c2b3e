# SPDX-License-Identifier: BSD-3-Clause
# IPC-6000 class boards: Core i5-8265U (Whiskey Lake = Skylake core: AVX2/FMA/BMI2, no AVX-512).
# Deliberately no CMAKE_SYSTEM_NAME: x86-64 -> x86-64 is not cross-compiling, so host-only steps (the lcm-spy
# Java jar, running tests) stay on. Binaries SIGILL on CPUs without AVX2 (Atom, pre-Haswell):
# configure with -DCM_IPC_MARCH=x86-64-v2 for those.
set(CMAKE_C_COMPILER   gcc)
set(CMAKE_CXX_COMPILER g++)
set(CM_IPC_MARCH "skylake" CACHE STRING "-march for the IPC-6000 target")
set(CMAKE_C_FLAGS_INIT   "-march=${CM_IPC_MARCH} -mtune=skylake")
set(CMAKE_CXX_FLAGS_INIT "-march=${CM_IPC_MARCH} -mtune=skylake")
