// The parts of three.js the animation page uses, bundled by `bundle.sh` into one script that
// sets `window.THREE` (no module loader, no network: the page inlines it).
import {
  AmbientLight, BoxGeometry, BufferAttribute, BufferGeometry, Color, CylinderGeometry,
  DirectionalLight, DoubleSide, EdgesGeometry, Float32BufferAttribute, GridHelper, Group,
  HemisphereLight, InstancedMesh, Line, LineBasicMaterial, LineSegments, Matrix4, Mesh,
  MeshBasicMaterial, MeshStandardMaterial, OrthographicCamera, PerspectiveCamera, PlaneGeometry,
  Scene, SphereGeometry, Vector3, WebGLRenderer, REVISION,
} from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

window.THREE = {
  AmbientLight, BoxGeometry, BufferAttribute, BufferGeometry, Color, CylinderGeometry,
  DirectionalLight, DoubleSide, EdgesGeometry, Float32BufferAttribute, GridHelper, Group,
  HemisphereLight, InstancedMesh, Line, LineBasicMaterial, LineSegments, Matrix4, Mesh,
  MeshBasicMaterial, MeshStandardMaterial, OrthographicCamera, PerspectiveCamera, PlaneGeometry,
  Scene, SphereGeometry, Vector3, WebGLRenderer, REVISION, OrbitControls,
};
