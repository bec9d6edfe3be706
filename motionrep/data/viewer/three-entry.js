// The parts of three.js the motionrep viewer uses, bundled into one classic script (three.min.js) that defines
// window.MOTIONREP_THREE. Rebuild: see README.md beside this file.
export {
  AnimationMixer, Box3, Color, CylinderGeometry, GridHelper, Group, InstancedMesh, Matrix4, Mesh,
  MeshBasicMaterial, Object3D, PerspectiveCamera, Quaternion, REVISION, SRGBColorSpace, Scene, SphereGeometry,
  Vector3, WebGLRenderer,
} from 'three';
export { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
export { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
