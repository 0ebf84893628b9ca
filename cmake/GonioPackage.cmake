# cpack -G DEB (in the build folder): the Debian package gonio_<version>_<arch>.deb, installed under
# /usr. Its dependencies come from the shared libraries the programs and the Python module link
# (dpkg-shlibdeps, package dpkg-dev), not from a hand-kept list. Nothing is done to the system at
# install: device access is the opt-in `gonio-device-access grant USER` (docs/install.md); the
# removal takes away the udev rule that step linked in (packaging/debian/postrm).
# cpack packages the build as it is (build first: `cmake --build build`), instead of building every
# target, tests included, before each package.
set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON)
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_PACKAGE_NAME gonio)
set(CPACK_PACKAGE_VENDOR gonio)
set(CPACK_PACKAGE_CONTACT "gonio maintainers <gonio@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "gonioreflectometer control, BRDF acquisition and model fitting")
set(CPACK_PACKAGE_DESCRIPTION
    "gonio drives the motors and the camera of a gonioreflectometer, plans and runs measurement\n"
    "campaigns, turns camera frames into calibrated BRDF values and fits analytic models to them.\n"
    "This package holds the programs gonio and gonio-full, the Python module, the static libraries\n"
    "with their headers and CMake package, the material library, rigs and models.")
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# The Python module links no libpython: dpkg-shlibdeps cannot see the interpreter it is built for
# (CPython's ABI of that minor version) nor numpy, which it imports.
if(GONIO_BUILD_PYTHON)
  string(REPLACE "." ";" py_version "${GONIO_PYTHON_MAJOR_MINOR}")
  list(GET py_version 0 py_major)
  list(GET py_version 1 py_minor)
  math(EXPR py_next "${py_minor} + 1")
  set(CPACK_DEBIAN_PACKAGE_DEPENDS
      "python3 (>= ${py_major}.${py_minor}), python3 (<< ${py_major}.${py_next}), python3-numpy")
endif()
# Maintainer scripts: prerm takes the Python bytecode away, postrm the opt-in udev rule's link.
if(GONIO_BUILD_PYTHON)
  configure_file(${PROJECT_SOURCE_DIR}/packaging/debian/prerm.in ${PROJECT_BINARY_DIR}/packaging/prerm
                 @ONLY FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE
                 WORLD_READ WORLD_EXECUTE)
  set(gonio_prerm ${PROJECT_BINARY_DIR}/packaging/prerm)
endif()
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${gonio_prerm} ${PROJECT_SOURCE_DIR}/packaging/debian/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_STRIP_FILES ON)
include(CPack)
