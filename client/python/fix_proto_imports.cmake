# SPDX-License-Identifier: Apache-2.0
# Copies protoc's Python output from STAGE to OUT (the nearpoint.proto package), turning the
# top-level imports of sibling modules ("import nearpoint_geometry_pb2 as x") into package-relative
# ones ("from . import nearpoint_geometry_pb2 as x"). Usage: cmake -DSTAGE=dir -DOUT=dir -P this
file(GLOB _files ${STAGE}/*.py)
file(MAKE_DIRECTORY ${OUT})
foreach(_file IN LISTS _files)
  file(READ ${_file} _text)
  string(REGEX REPLACE "\nimport (nearpoint_[a-z_]+_pb2) as " "\nfrom . import \\1 as " _text
                       "${_text}")
  if(_text MATCHES "\nimport nearpoint_")
    message(FATAL_ERROR "${_file}: a top-level import of a nearpoint module is left")
  endif()
  get_filename_component(_name ${_file} NAME)
  file(WRITE ${OUT}/${_name} "${_text}")
endforeach()
