// SPDX-License-Identifier: BSD-3-Clause
// The scan fixtures moved to tests/support/scan_chunks.hpp; this header forwards to it for the tests that still
// include it by its old path.
#pragma once

#include "tests/support/scan_chunks.hpp"
