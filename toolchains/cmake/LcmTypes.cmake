# SPDX-License-Identifier: BSD-3-Clause
# lcm-gen at build time. Convention: one struct per .lcm file, struct name == file basename, optional
# `package x;`. C++ headers land in <build>/lcmgen/cpp/<package>/<type>.hpp (include as <package/type.hpp>);
# with JAVA_JAR, the same types are compiled into <build>/<jar>.jar for lcm-spy. Generated code is never
# committed.

find_program(LCM_GEN_EXECUTABLE lcm-gen REQUIRED NO_CMAKE_FIND_ROOT_PATH)  # host lcm-gen, also when cross

function(cm_lcm_types target)
  cmake_parse_arguments(ARG "" "JAVA_JAR" "FILES" ${ARGN})
  set(cpp_dir "${CMAKE_CURRENT_BINARY_DIR}/lcmgen/cpp")
  set(java_dir "${CMAKE_CURRENT_BINARY_DIR}/lcmgen/java")
  set(cpp_out "")
  set(java_out "")
  foreach(lcm IN LISTS ARG_FILES)
    get_filename_component(lcm_abs "${lcm}" ABSOLUTE)
    get_filename_component(type "${lcm}" NAME_WE)
    file(STRINGS "${lcm_abs}" pkg_line REGEX "^[ \t]*package[ \t]+[A-Za-z0-9_.]+[ \t]*;")
    set(pkg_dir "")
    if(pkg_line)
      string(REGEX REPLACE "^[ \t]*package[ \t]+([A-Za-z0-9_.]+).*" "\\1" pkg "${pkg_line}")
      string(REPLACE "." "/" pkg_dir "${pkg}")
    endif()
    set(hpp "${cpp_dir}/${pkg_dir}/${type}.hpp")
    add_custom_command(OUTPUT "${hpp}"
      COMMAND "${LCM_GEN_EXECUTABLE}" --cpp --cpp-std c++11 --cpp-hpath "${cpp_dir}" "${lcm_abs}"
      DEPENDS "${lcm_abs}" COMMENT "lcm-gen (C++) ${type}" VERBATIM)
    list(APPEND cpp_out "${hpp}")
    if(ARG_JAVA_JAR)
      if(pkg_dir STREQUAL "")
        set(jfile "${java_dir}/lcmtypes/${type}.java")
      else()
        set(jfile "${java_dir}/${pkg_dir}/${type}.java")
      endif()
      add_custom_command(OUTPUT "${jfile}"
        COMMAND "${LCM_GEN_EXECUTABLE}" --java --jpath "${java_dir}" "${lcm_abs}"
        DEPENDS "${lcm_abs}" COMMENT "lcm-gen (Java) ${type}" VERBATIM)
      list(APPEND java_out "${jfile}")
    endif()
  endforeach()
  add_custom_target(${target}_gen DEPENDS ${cpp_out})
  add_library(${target} INTERFACE)
  target_include_directories(${target} INTERFACE "${cpp_dir}")
  target_link_libraries(${target} INTERFACE lcm::lcm)
  add_dependencies(${target} ${target}_gen)
  if(ARG_JAVA_JAR AND java_out)
    find_package(Java COMPONENTS Development)
    find_file(LCM_JAR lcm.jar PATHS /usr/share/java /usr/local/share/java NO_CMAKE_FIND_ROOT_PATH)
    if(Java_FOUND AND LCM_JAR)
      include(UseJava)
      add_jar(${ARG_JAVA_JAR} SOURCES ${java_out} INCLUDE_JARS "${LCM_JAR}")
      set(CM_LCM_JAR "${LCM_JAR}" PARENT_SCOPE)
    else()
      message(WARNING "javac or lcm.jar not found: the lcm-spy type jar ${ARG_JAVA_JAR} is not built")
    endif()
  endif()
endfunction()
