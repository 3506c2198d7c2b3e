# SPDX-License-Identifier: BSD-3-Clause
# One place for compile settings: every commerge target calls cm_set_target_defaults().

set(CMAKE_CXX_STANDARD 17)
set(CMAKE_CXX_STANDARD_REQUIRED ON)
set(CMAKE_CXX_EXTENSIONS OFF)
set(CMAKE_POSITION_INDEPENDENT_CODE ON)

if(CM_SANITIZE)
  if(CMAKE_CROSSCOMPILING)
    message(FATAL_ERROR "CM_SANITIZE is for host builds (qemu-user does not run ASan binaries reliably)")
  endif()
  set(CM_SANITIZE_FLAGS -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
endif()

function(cm_set_target_defaults target)
  target_compile_features(${target} PUBLIC cxx_std_17)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wshadow -Wdouble-promotion -Wnon-virtual-dtor
                         $<$<BOOL:${CM_WERROR}>:-Werror>)
  if(CM_SANITIZE)
    target_compile_options(${target} PRIVATE ${CM_SANITIZE_FLAGS})
    target_link_options(${target} PRIVATE ${CM_SANITIZE_FLAGS})
  endif()
endfunction()
