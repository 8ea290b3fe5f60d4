# Debian packages with CPack, one per install component:
#   impostor-server   /usr/bin/impostor-server, its unit, /etc/impostor/server.conf
#   impostor-worker   /usr/bin/impostor-worker, its unit template, /etc/impostor/worker.conf
#                     (Depends: mesa-vulkan-drivers: lavapipe when there is no GPU)
#   impostor-cli      /usr/bin/impostor (Depends: libimpostorX.Y)
#   libimpostorX.Y    the shared libraries: libimpostor.so.X.Y*, libimpostor_runtime.so.X.Y*
#                     (named after the SONAME, Debian policy 8.1; shlibs file, ldconfig
#                     run by its generated postinst/postrm)
#   libimpostor-dev   the SDK: the libimpostor.so and libimpostor_runtime.so links,
#                     headers, CMake package and pkg-config file (Depends: libimpostorX.Y
#                     of the same version)
# Each binary's man page goes with it. Server and worker create the system
# user `impostor` and /var/lib/impostor (deploy/debian/postinst); removing
# them leaves that directory alone. Library dependencies come from
# dpkg-shlibdeps.
#
# Build them from an already built tree (nothing is recompiled):
#   cmake --build build --target impostor_packages     # -> build/packages/*.deb
# deploy/package-test.sh installs them and bakes through the packaged server.
include_guard(GLOBAL)
include(GNUInstallDirs)

# System files: absolute destinations, as a Debian package has them (a
# `cmake --install --component server|worker` as root puts them there too).
# EXCLUDE_FROM_ALL: a whole-tree `cmake --install --prefix P` (a developer's
# staging prefix) stays inside P and needs no root.
set(_deploy ${CMAKE_SOURCE_DIR}/deploy)
if(TARGET impostor-server)
  install(FILES ${_deploy}/systemd/impostor-server.service DESTINATION /lib/systemd/system COMPONENT server EXCLUDE_FROM_ALL)
  install(FILES ${_deploy}/debian/server.conf DESTINATION /etc/impostor COMPONENT server EXCLUDE_FROM_ALL)
  # The dashboard (--http-listen) finds its files here (share/impostor/web
  # beside bin/): the pages, and the pinned three.js build and addons they
  # import (web/node_modules, from `npm ci` in deploy/install-deps.sh).
  set(_web ${CMAKE_SOURCE_DIR}/web)
  set(_web_dest ${CMAKE_INSTALL_DATADIR}/impostor/web)
  install(DIRECTORY ${_web}/ DESTINATION ${_web_dest} COMPONENT server
    PATTERN node_modules EXCLUDE PATTERN package.json EXCLUDE PATTERN package-lock.json EXCLUDE)
  if(EXISTS ${_web}/node_modules/three/build)
    install(DIRECTORY ${_web}/node_modules/three/build DESTINATION ${_web_dest}/node_modules/three COMPONENT server)
    install(DIRECTORY ${_web}/node_modules/three/examples/jsm DESTINATION ${_web_dest}/node_modules/three/examples
      COMPONENT server)
    install(FILES ${_web}/node_modules/three/LICENSE DESTINATION ${_web_dest}/node_modules/three COMPONENT server)
  endif()
  # The viewer draws with the impostor-three package (web/package.json links
  # it from packages/): installed from the sources, as npm would lay it out.
  set(_three_pkg ${CMAKE_SOURCE_DIR}/packages/impostor-three)
  install(FILES ${_three_pkg}/package.json DESTINATION ${_web_dest}/node_modules/impostor-three COMPONENT server)
  install(DIRECTORY ${_three_pkg}/src DESTINATION ${_web_dest}/node_modules/impostor-three COMPONENT server)
endif()
if(TARGET impostor-worker)
  install(FILES ${_deploy}/systemd/impostor-worker@.service DESTINATION /lib/systemd/system COMPONENT worker EXCLUDE_FROM_ALL)
  install(FILES ${_deploy}/debian/worker.conf DESTINATION /etc/impostor COMPONENT worker EXCLUDE_FROM_ALL)
endif()

# Maintainer scripts: postinst and postrm are shared; prerm names the
# package's own units.
set(_scripts ${CMAKE_BINARY_DIR}/debian)
foreach(_pair "server|impostor-server.service" "worker|impostor-worker@*.service")
  string(REPLACE "|" ";" _pair "${_pair}")
  list(GET _pair 0 _component)
  list(GET _pair 1 IMPOSTOR_UNITS)
  set(IMPOSTOR_PACKAGE impostor-${_component})
  configure_file(${_deploy}/debian/prerm.in ${_scripts}/${_component}/prerm @ONLY
    FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
  # /etc files are configuration: dpkg keeps local edits on upgrade.
  file(WRITE ${_scripts}/${_component}/conffiles "/etc/impostor/${_component}.conf\n")
endforeach()

set(CPACK_PACKAGE_NAME impostor)
set(CPACK_PACKAGE_VENDOR "impostor bake farm")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "impostor bake farm maintainers <impostor@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "bake impostor atlases from glTF meshes on a farm of Vulkan workers")
set(CPACK_PACKAGE_DIRECTORY ${CMAKE_BINARY_DIR}/packages)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_GENERATOR DEB)
set(CPACK_COMPONENTS_ALL server worker cli lib sdk)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# Release packages: no debug info in the binaries (smaller, faster to build).
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
# Maintainer scripts get Debian's modes (0755), whatever the checkout's.
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)

set(CPACK_DEBIAN_SERVER_PACKAGE_NAME impostor-server)
set(CPACK_DEBIAN_SERVER_PACKAGE_DEPENDS "adduser, libpq5")
set(CPACK_DEBIAN_SERVER_DESCRIPTION "impostor bake farm: the gRPC server (blob store, job queue, worker leases)")
set(CPACK_DEBIAN_SERVER_PACKAGE_CONTROL_EXTRA
  ${_deploy}/debian/postinst ${_deploy}/debian/postrm ${_scripts}/server/prerm ${_scripts}/server/conffiles)

set(CPACK_DEBIAN_WORKER_PACKAGE_NAME impostor-worker)
set(CPACK_DEBIAN_WORKER_PACKAGE_DEPENDS "adduser, mesa-vulkan-drivers")
set(CPACK_DEBIAN_WORKER_DESCRIPTION "impostor bake farm: a bake worker (headless Vulkan; lavapipe without a GPU)")
set(CPACK_DEBIAN_WORKER_PACKAGE_CONTROL_EXTRA
  ${_deploy}/debian/postinst ${_deploy}/debian/postrm ${_scripts}/worker/prerm ${_scripts}/worker/conffiles)

set(CPACK_DEBIAN_CLI_PACKAGE_NAME impostor-cli)
# The CLI and the runtime library come from one build and are installed and
# upgraded together: an exact version, as for -dev.
set(CPACK_DEBIAN_CLI_PACKAGE_DEPENDS "${IMPOSTOR_LIB_PACKAGE} (= ${PROJECT_VERSION})")
set(CPACK_DEBIAN_CLI_DESCRIPTION "impostor bake farm: the `impostor` command-line client")

set(CPACK_DEBIAN_LIB_PACKAGE_NAME ${IMPOSTOR_LIB_PACKAGE})
set(CPACK_DEBIAN_LIB_PACKAGE_SECTION libs)
# libcurl is opened with dlopen when a download from a mirror first needs it
# (client/delivery/curl_library.h), so dpkg-shlibdeps cannot see it.
set(CPACK_DEBIAN_LIB_PACKAGE_DEPENDS "libcurl4")
set(CPACK_DEBIAN_LIB_DESCRIPTION
  "impostor bake farm SDK: shared libraries (libimpostor: client, cache, C API; libimpostor_runtime)")
# DEBIAN/shlibs, so packages linking these libraries get the dependency from
# dpkg-shlibdeps; ldconfig runs from the postinst/postrm CPack generates for
# libraries under /usr/lib. (A global switch in CPack; only this package
# has shared objects.)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)

set(CPACK_DEBIAN_SDK_PACKAGE_NAME libimpostor-dev)
set(CPACK_DEBIAN_SDK_PACKAGE_SECTION libdevel)
# The public headers include Abseil's Status; the CMake package finds it.
# The .so links point into the runtime package of exactly this version.
set(CPACK_DEBIAN_SDK_PACKAGE_DEPENDS "libabsl-dev, ${IMPOSTOR_LIB_PACKAGE} (= ${PROJECT_VERSION})")
set(CPACK_DEBIAN_SDK_DESCRIPTION
  "impostor bake farm SDK: C++ client, result cache, runtime math and C API (find_package(impostor), pkg-config impostor)")

include(CPack)

# Packages from the built tree: build what they contain, then run cpack
# (which only copies: `cmake --install` per component).
set(_packaged)
foreach(_target impostor-server impostor-worker impostor impostor_sdk_shared impostor_runtime_shared impostor_man_pages)
  if(TARGET ${_target})
    list(APPEND _packaged ${_target})
  endif()
endforeach()
add_custom_target(impostor_packages
  COMMAND ${CMAKE_CPACK_COMMAND} --config ${CMAKE_BINARY_DIR}/CPackConfig.cmake
  WORKING_DIRECTORY ${CMAKE_BINARY_DIR}
  DEPENDS ${_packaged}
  COMMENT "Debian packages in ${CMAKE_BINARY_DIR}/packages"
  VERBATIM)

# The packages installed on this machine (root and apt-get; skipped
# otherwise), not in the default run: deploy/test.sh runs it after the rest.
if(IMPOSTOR_BUILD_TESTS)
  add_test(NAME debian_packages COMMAND bash ${CMAKE_SOURCE_DIR}/deploy/package-test.sh ${CMAKE_BINARY_DIR})
  set_tests_properties(debian_packages PROPERTIES LABELS packaging TIMEOUT 1200 SKIP_RETURN_CODE 77 RUN_SERIAL ON)
endif()
