# Man pages for the three binaries, made at build time from their own
# --help and --version (cmake/help_to_man.cmake), installed with each
# binary's component; tested to render cleanly and show every flag.
include_guard(GLOBAL)
include(GNUInstallDirs)

set(_impostor_man_pages)
foreach(_entry
    "impostor-server|server|the impostor bake farm's gRPC server"
    "impostor-worker|worker|a bake worker of the impostor bake farm (headless Vulkan)"
    "impostor|cli|command-line client of the impostor bake farm")
  string(REPLACE "|" ";" _entry "${_entry}")
  list(GET _entry 0 _binary)
  list(GET _entry 1 _component)
  list(GET _entry 2 _summary)
  if(NOT TARGET ${_binary})
    continue()
  endif()
  set(_page ${CMAKE_BINARY_DIR}/man/${_binary}.1)
  add_custom_command(OUTPUT ${_page}
    COMMAND ${CMAKE_COMMAND} -DBINARY=$<TARGET_FILE:${_binary}> -DNAME=${_binary} "-DSUMMARY=${_summary}"
      -DOUT=${_page} -P ${CMAKE_SOURCE_DIR}/cmake/help_to_man.cmake
    DEPENDS ${_binary} ${CMAKE_SOURCE_DIR}/cmake/help_to_man.cmake
    COMMENT "man page ${_binary}.1" VERBATIM)
  list(APPEND _impostor_man_pages ${_page})
  install(FILES ${_page} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT ${_component})
  if(IMPOSTOR_BUILD_TESTS)
    find_program(IMPOSTOR_GROFF groff)
    if(IMPOSTOR_GROFF)
      add_test(NAME man_page_${_binary}
        COMMAND ${CMAKE_COMMAND} -DBINARY=$<TARGET_FILE:${_binary}> -DPAGE=${_page}
          -P ${CMAKE_SOURCE_DIR}/cmake/check_man_page.cmake)
      set_tests_properties(man_page_${_binary} PROPERTIES LABELS unit TIMEOUT 60)
    endif()
  endif()
endforeach()
if(_impostor_man_pages)
  add_custom_target(impostor_man_pages ALL DEPENDS ${_impostor_man_pages})
endif()
