# SPDX-License-Identifier: Apache-2.0
# Man pages for nearpoint(1) and nearpointd(1), made from their --help at build time with
# help2man (Debian's help2man), every subcommand's --help included (cmake/man_page.py), and
# installed to share/man/man1. Without help2man or Python the build leaves them out and says so.
#
# Shell completion is not generated: CLI11 (2.3, Debian 12) has no completion generator, and a
# hand-written script would be one more copy of the flags to keep in step.
find_program(NEARPOINT_HELP2MAN help2man)
find_package(Python3 COMPONENTS Interpreter QUIET)
if(NOT NEARPOINT_HELP2MAN OR NOT Python3_Interpreter_FOUND)
  message(STATUS "nearpoint: help2man or python3 not found, the man pages are not built "
                 "(deploy/install-deps.sh installs help2man)")
  return()
endif()

set(NEARPOINT_MAN_DIR ${PROJECT_BINARY_DIR}/man)
set(_nearpoint_man_pages)
# nearpoint_man_page(TARGET "NAME LINE" SEE_ALSO): man/TARGET.1 from TARGET's --help.
function(nearpoint_man_page target name_line see_also)
  if(NOT TARGET ${target})
    return()
  endif()
  set(page ${NEARPOINT_MAN_DIR}/${target}.1)
  add_custom_command(
    OUTPUT ${page}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${NEARPOINT_MAN_DIR}
    COMMAND Python3::Interpreter ${PROJECT_SOURCE_DIR}/cmake/man_page.py ${NEARPOINT_HELP2MAN}
            $<TARGET_FILE:${target}> ${PROJECT_VERSION} ${name_line} ${see_also} ${page}
    DEPENDS ${target} ${PROJECT_SOURCE_DIR}/cmake/man_page.py
    COMMENT "Man page ${target}.1 from ${target} --help"
    VERBATIM)
  install(FILES ${page} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT runtime)
  set(_nearpoint_man_pages ${_nearpoint_man_pages} ${page} PARENT_SCOPE)
endfunction()

nearpoint_man_page(nearpoint "distances between convex shapes, locally or from nearpointd"
                   nearpointd)
nearpoint_man_page(nearpointd "distance server for convex shapes (gRPC and DDS)" nearpoint)
if(_nearpoint_man_pages)
  # Part of `all`, so that `cmake --install` always finds them.
  add_custom_target(nearpoint_man_pages ALL DEPENDS ${_nearpoint_man_pages})
endif()
