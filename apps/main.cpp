// SPDX-License-Identifier: BSD-3-Clause
#include <cstdio>
int main() { std::puts("commerge " CM_VERSION); return 0; }
