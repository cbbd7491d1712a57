# FindMuJoCo.cmake — libmujoco (Debian: libmujoco-dev), the MJCF/URDF reader of
# modal's import stage. Creates the imported target MuJoCo::MuJoCo.
#
# Debian's package ships a CMake config (mujocoConfig.cmake), but its target
# names /usr/include/libqhull_r/ as an include directory, which no package
# installs, and it requires OpenGL's development files: CMake refuses the
# target. modal needs only the header and the library, found here.
find_path(MuJoCo_INCLUDE_DIR mujoco/mujoco.h)
find_library(MuJoCo_LIBRARY NAMES mujoco)
if(MuJoCo_INCLUDE_DIR AND EXISTS "${MuJoCo_INCLUDE_DIR}/mujoco/mujoco.h")
  file(STRINGS "${MuJoCo_INCLUDE_DIR}/mujoco/mujoco.h" _mujoco_version_line REGEX "#define mjVERSION_HEADER")
  string(REGEX REPLACE ".*mjVERSION_HEADER ([0-9])([0-9])([0-9]).*" "\\1.\\2.\\3" MuJoCo_VERSION "${_mujoco_version_line}")
endif()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(MuJoCo REQUIRED_VARS MuJoCo_LIBRARY MuJoCo_INCLUDE_DIR VERSION_VAR MuJoCo_VERSION)
if(MuJoCo_FOUND AND NOT TARGET MuJoCo::MuJoCo)
  add_library(MuJoCo::MuJoCo UNKNOWN IMPORTED)
  set_target_properties(MuJoCo::MuJoCo PROPERTIES IMPORTED_LOCATION "${MuJoCo_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${MuJoCo_INCLUDE_DIR}")
endif()
mark_as_advanced(MuJoCo_INCLUDE_DIR MuJoCo_LIBRARY)
