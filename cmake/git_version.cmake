# git_version.cmake — writes version.h (project version and git hash for provenance) at every
# build, not only at configure time: a tree built, committed and rebuilt without re-running cmake
# would otherwise record the old commit in every provenance group. The file is rewritten only when
# its text changes, so an unchanged tree recompiles nothing.
#   cmake -DPF_SOURCE_DIR=<repo> -DIN=version.h.in -DOUT=version.h -DPROJECT_VERSION=x.y.z -P ...
# The hash gets "-dirty" when tracked files differ from the commit (a run from an uncommitted tree
# must not claim to be that commit); "unknown" outside a git checkout.
cmake_minimum_required(VERSION 3.20)
execute_process(COMMAND git rev-parse --short=12 HEAD
                WORKING_DIRECTORY ${PF_SOURCE_DIR}
                OUTPUT_VARIABLE PF_GIT_HASH OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR NOT PF_GIT_HASH)
  set(PF_GIT_HASH "unknown")
else()
  execute_process(COMMAND git status --porcelain --untracked-files=no
                  WORKING_DIRECTORY ${PF_SOURCE_DIR}
                  OUTPUT_VARIABLE changes OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(changes)
    string(APPEND PF_GIT_HASH "-dirty")
  endif()
endif()
configure_file(${IN} ${OUT}.new @ONLY)
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different ${OUT}.new ${OUT})
file(REMOVE ${OUT}.new)
